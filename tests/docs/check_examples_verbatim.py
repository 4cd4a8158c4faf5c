"""The code the README and the quick starts show is the code the tests run: each listed block must
equal its example file (the C++ one between its `// README begin` and `// README end` markers).
Usage: check_examples_verbatim.py REPO"""
import pathlib
import re
import sys

repo = pathlib.Path(sys.argv[1])
# (document, fence language, n-th block of that language in it, example file)
PAIRS = [
    ("README.md", "cpp", 0, "examples/solve_matrix_market.cpp"),
    ("README.md", "python", 0, "examples/python/readme_example.py"),
    ("docs/quickstart-scipy.md", "python", 0, "examples/python/quickstart_scipy.py"),
]


def blocks(text, lang):
    return [m.group(1) for m in re.finditer(r"^```" + lang + r"[^\n]*\n(.*?)^```", text, re.S | re.M)]


failed = 0
for doc, lang, k, example in PAIRS:
    shown = blocks((repo / doc).read_text(), lang)
    code = (repo / example).read_text()
    if "// README begin\n" in code:
        code = code.split("// README begin\n", 1)[1].split("// README end", 1)[0]
    if len(shown) <= k:
        print(f"{doc}: no {lang} block #{k + 1} (it should show {example})")
        failed += 1
    elif shown[k] != code:
        print(f"{doc}: {lang} block #{k + 1} differs from {example}")
        failed += 1
    else:
        print(f"{doc}: {lang} block #{k + 1} is {example}")
sys.exit(1 if failed else 0)
