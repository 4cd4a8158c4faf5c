"""The seams between pmgkit's libraries, checked on the source tree (docs/design.md, "Seams"):

1. What a solver needs of an FEM system (SolverNeeds) is read in one file, fem/src/bound_system.cpp;
   elsewhere it is only answered (`SolverNeeds needs() const override`) or declared.
2. No dynamic_cast to a type of another library: a component asks an operator, a level provider
   or a solver what it offers through the core's capability queries instead.
3. No concrete adapter type (CholmodSolver, BoomerAmg, ...) named outside its adapter: other
   libraries get those solvers from the factory.
4. No function of the libraries longer than MAX_LINES (tests, benchmarks and examples aside).

Usage: check_seam.py SOURCE_DIR [--report]. Exits 1 naming every violation; --report prints the
counts (for the design doc) and exits 0.
"""
import pathlib
import re
import sys

LIBRARIES = ["sparse", "multigrid", "fem", "gpu", "adapters", "solvers", "distributed", "sim", "study", "tools",
             "python/src"]
SOURCES = (".cpp", ".hpp", ".cu", ".cuh")
MAX_LINES = 120


def library_of(path: pathlib.Path, root: pathlib.Path) -> str:
    rel = path.relative_to(root).as_posix()
    parts = rel.split("/")
    if parts[0] == "adapters":  # each adapter is its own library
        return "/".join(parts[:2])
    if parts[0] == "python":
        return "python"
    return parts[0]


def files(root: pathlib.Path):
    for lib in LIBRARIES:
        base = root / lib
        if not base.exists():
            continue
        for p in sorted(base.rglob("*")):
            if p.suffix in SOURCES and p.is_file():
                yield p


def strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def declared_types(root: pathlib.Path):
    """type name -> set of libraries declaring it (class/struct definitions, not forward declarations)."""
    where = {}
    for p in files(root):
        for m in re.finditer(r"\b(?:class|struct)\s+(\w+)\s*(?:final\s*)?[:{]", strip_comments(p.read_text())):
            where.setdefault(m.group(1), set()).add(library_of(p, root))
    return where


def check_needs(root, problems):
    reads = 0
    for p in files(root):
        rel = p.relative_to(root).as_posix()
        for n, line in enumerate(strip_comments(p.read_text()).splitlines(), 1):
            if not re.search(r"\bneeds\(\)|\bneeds_\.|SolverNeeds\{", line):
                continue
            if re.search(r"SolverNeeds\s+needs\(\)\s*const", line):
                continue  # a solver answering (or forwarding) what it needs
            if rel == "fem/src/bound_system.cpp":
                reads += 1
                continue
            problems.append(f"{rel}:{n}: SolverNeeds read outside fem/src/bound_system.cpp: {line.strip()}")
    return reads


def check_casts(root, problems, types):
    casts = 0
    for p in files(root):
        rel, lib = p.relative_to(root).as_posix(), library_of(p, root)
        for n, line in enumerate(strip_comments(p.read_text()).splitlines(), 1):
            for m in re.finditer(r"dynamic_cast<\s*(?:const\s+)?([\w:]+)", line):
                casts += 1
                name = m.group(1).split("::")[-1]
                homes = types.get(name, set())
                if lib not in homes:
                    problems.append(f"{rel}:{n}: dynamic_cast to {m.group(1)} (declared in {sorted(homes) or '?'}), "
                                    f"across the boundary of {lib}: ask a capability instead")
    return casts


def check_adapter_types(root, problems):
    adapter_types = {}
    for p in (root / "adapters").rglob("*.hpp"):
        for m in re.finditer(r"\bclass\s+(\w+)\s+(?:final\s*)?:\s*public\s+(?:pmg::)?Solver\b", p.read_text()):
            adapter_types[m.group(1)] = library_of(p, root)
    for p in files(root):
        rel, lib = p.relative_to(root).as_posix(), library_of(p, root)
        text = re.sub(r'"(?:\\.|[^"\\\n])*"', '""', strip_comments(p.read_text()))  # names in messages are words
        for name, home in adapter_types.items():
            if home != lib and re.search(rf"\b{name}\b", text):
                problems.append(f"{rel}: names the concrete adapter type {name} of {home}: build it with the factory")
    return len(adapter_types)


def function_lengths(root):
    """(lines, file:line, name) of function bodies in .cpp/.cu files, by brace matching at namespace depth."""
    out = []
    for p in files(root):
        if p.suffix not in (".cpp", ".cu"):
            continue
        text = strip_comments(p.read_text())
        text = re.sub(r'"(?:\\.|[^"\\\n])*"', '""', text)  # braces inside strings
        text = re.sub(r"'(?:\\.|[^'\\\n])'", "''", text)
        lines = text.splitlines()
        depth, start, head = 0, None, ""
        scopes = []  # True for a namespace/class/struct/enum scope, False for a function body or other block
        for i, line in enumerate(lines):
            for j, ch in enumerate(line):
                if ch == "{":
                    before = (head + line[:j]).strip()
                    is_scope = bool(re.search(r"\b(namespace|class|struct|enum|union)\b[^;()]*$", before)) or before.endswith("extern \"C\"")
                    is_function = (not is_scope and all(scopes) and
                                   re.search(r"\)\s*(const)?\s*(noexcept)?\s*(override|final)?\s*(->\s*[\w:<>&*, ]+)?\s*(:[^;]*)?$", before) is not None
                                   and not re.search(r"\b(if|for|while|switch|catch|return)\b\s*\(", before.split(";")[-1]))
                    scopes.append(is_scope)
                    if is_function and start is None:
                        start = (i, before.split(";")[-1].split("}")[-1].strip()[-80:])
                    head = ""
                elif ch == "}":
                    if scopes:
                        scopes.pop()
                    if start is not None and all(scopes):
                        out.append((i - start[0] + 1, f"{p.relative_to(root).as_posix()}:{start[0] + 1}", start[1]))
                        start = None
                    head = ""
                elif ch == ";":
                    head = ""
            head += line + " "
            head = head[-400:]
    return out


def main():
    root = pathlib.Path(sys.argv[1]).resolve()
    report = "--report" in sys.argv
    problems = []
    types = declared_types(root)
    reads = check_needs(root, problems)
    casts = check_casts(root, problems, types)
    check_adapter_types(root, problems)
    long = sorted((f for f in function_lengths(root) if f[0] > MAX_LINES), reverse=True)
    for n, where, name in long:
        problems.append(f"{where}: function of {n} lines (> {MAX_LINES}): {name}")
    if report:
        print(f"SolverNeeds reads in fem/src/bound_system.cpp: {reads}; dynamic_casts in the libraries: {casts}")
        print(f"functions over {MAX_LINES} lines: {len(long)}")
        for line in problems:
            print(line)
        return 0
    if problems:
        print("\n".join(problems))
        print(f"{len(problems)} seam violation(s)")
        return 1
    print(f"seams hold: SolverNeeds read in one file, {casts} dynamic_casts all within their library, "
          f"no adapter type outside its adapter, no library function over {MAX_LINES} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
