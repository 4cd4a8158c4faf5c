"""The CLI tells the truth: `pmg solvers`, `pmg compare --help` and docs/solvers.md list exactly the
methods of the registry, with the registry's keys and defaults.

  check_method_lists.py PMG DOCS_SOLVERS_MD

docs/solvers.md is `pmg solvers --markdown` of a full build; a build without a component (the GPU
module where nvcc is absent) compares the file without that component's rows and sections.
"""
import re
import subprocess
import sys

pmg, doc_path = sys.argv[1], sys.argv[2]


def run(*args):
    r = subprocess.run([pmg, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"pmg {' '.join(args)} failed ({r.returncode}): {r.stderr}")
    return r.stdout


# The registry, as pmg solvers prints it: "name [component] ..." lines.
text = run("solvers")
registry = re.findall(r"^(\S+) \[(\w+)\]", text, re.M)
names = [n for n, _ in registry]
components = {c for _, c in registry}
assert len(names) >= 20 and len(set(names)) == len(names), names
for must in ["cg", "mcg", "pmg", "mgpcg", "cholmod", "boomeramg-pcg", "gamg-pcg", "mumps", "chebyshev"]:
    assert must in names, f"{must} missing from pmg solvers: {names}"

# pmg compare --help lists the same methods, in the same order (generated, not typed).
help_text = " ".join(run("compare", "--help").split())
m = re.search(r"comma-separated methods: (.*?) \(default:", help_text)
assert m, "pmg compare --help has no method list"
listed = [s.strip() for s in m.group(1).split(",")]
assert listed == names, f"pmg compare --help lists {listed}, the registry holds {names}"
for retired in ["--smoother", "--lowest-level", "--mgpcg-cycles"]:
    assert retired not in help_text, f"{retired} is retired but still in the help"

# docs/solvers.md is the registry's Markdown (sections of components this build lacks dropped).
generated = run("solvers", "--markdown")
doc = open(doc_path).read()


def drop_components(md, keep):
    out, skip = [], False
    for line in md.splitlines(keepends=True):
        row = re.match(r"^\| \[`([^`]+)`\]\(#[^)]*\) \| (\w+) \|", line)
        if row and row.group(2) not in keep:
            continue
        head = re.match(r"^## (\S+)$", line)
        if head:
            skip = head.group(1) in doc_methods and doc_methods[head.group(1)] not in keep
            if skip and out and not out[-1].strip():
                out.pop()  # the blank line that opened the dropped section
        if not skip:
            out.append(line)
    return "".join(out)


doc_methods = dict(re.findall(r"^\| \[`([^`]+)`\]\(#[^)]*\) \| (\w+) \|", doc, re.M))
missing = [n for n in names if n not in doc_methods]
assert not missing, f"docs/solvers.md lacks {missing}: regenerate it (pmg solvers --markdown > docs/solvers.md)"
if drop_components(doc, components) != generated:
    import difflib
    sys.stdout.writelines(difflib.unified_diff(drop_components(doc, components).splitlines(True),
                                               generated.splitlines(True), "docs/solvers.md", "pmg solvers --markdown"))
    sys.exit("docs/solvers.md differs from the registry: regenerate it with pmg solvers --markdown > docs/solvers.md")
print(f"{len(names)} methods of {len(components)} components: pmg solvers, pmg compare --help and docs/solvers.md agree")
