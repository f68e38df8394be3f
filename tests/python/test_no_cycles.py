"""No circles between files (docs/architecture.md, "Layers"): the runtime (sdk/src), the samples and the tools
(tools/pleat) each form a graph of files with no strongly connected component larger than one node.

What counts, in C (sdk/src and samples, each its own graph):
- A node is a source stem: X.h and X.c in the same folder are one node (the header is the .c file's interface). A
  header without a .c file of its stem (kernels.h, jobs.h, core.h) is a node of its own.
- A file depends on the node of every header it includes (`#include "..."`, resolved from its own folder, then
  sdk/src and sdk/include), and a .c file on the node of every .c file that defines a non-static function it names
  (a call, or a function pointer taken for a table): the definitions and the names come from the sources with
  comments and strings removed, so no build is needed. A name defined in more than one .c file names alternatives
  that never link together (the GL deformer and its stub, each program's main) and counts for none of them.
What counts in Python (tools/pleat): a node is a module (a package's __init__ is its own); a module depends on every
module it imports anywhere in its text, function-level imports included (`from pkg import name` names the module
pkg.name where there is one, else pkg).

Any component of two or more files fails the test.
"""
import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

C_KEYWORDS = {"if", "for", "while", "switch", "return", "sizeof", "else", "do", "case", "defined"}


def strongly_connected(graph):
    """Tarjan's components of {node: set(nodes)}, iteratively (deep include chains would exhaust the recursion)."""
    index, low, on_stack, stack, out, counter = {}, {}, set(), [], [], [0]
    nodes = set(graph) | {w for ws in graph.values() for w in ws}
    for root in sorted(nodes):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = set()
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        component.add(w)
                        if w == v:
                            break
                    out.append(component)
    return out


def _strip_c(text):
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    text = re.sub(r"'(\\.|[^'\\])'", "' '", text)
    return re.sub(r'"(\\.|[^"\\\n])*"', '""', text)


_DEFINITION = re.compile(r"^(?!static\b)(?!extern\b)[A-Za-z_][\w \t\*]*?\b([A-Za-z_]\w*)\s*\(([^;{}()]|\([^;{}]*?\))*\)\s*\{",
                         re.M)
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def c_graph(tree):
    """{node: set(nodes)} of the C files under `tree` and, per edge, why (for the failure message)."""
    files = sorted(p for p in (ROOT / tree).rglob("*") if p.suffix in (".c", ".h"))
    node = {p: str(p.relative_to(ROOT).with_suffix("")) for p in files}
    by_path = {p.resolve(): p for p in files}
    graph, why = {n: set() for n in node.values()}, {}
    definitions = {}
    stripped = {p: _strip_c(p.read_text(encoding="utf-8", errors="replace")) for p in files}
    for p in files:
        if p.suffix == ".c":
            for m in _DEFINITION.finditer(stripped[p]):
                if m.group(1) not in C_KEYWORDS:
                    definitions.setdefault(m.group(1), set()).add(node[p])
    for p in files:
        raw = p.read_text(encoding="utf-8", errors="replace")
        for m in _INCLUDE.finditer(raw):
            for base in (p.parent, ROOT / "sdk/src", ROOT / "sdk/include"):
                target = by_path.get((base / m.group(1)).resolve())
                if target is not None:
                    if node[target] != node[p]:
                        graph[node[p]].add(node[target])
                        why.setdefault((node[p], node[target]), f'#include "{m.group(1)}"')
                    break
        if p.suffix != ".c":
            continue
        for name in set(re.findall(r"\b[A-Za-z_]\w*\b", stripped[p])):
            owners = definitions.get(name, ())
            for owner in owners if len(owners) == 1 else ():
                if owner != node[p]:
                    graph[node[p]].add(owner)
                    why.setdefault((node[p], owner), name)
    return graph, why


def python_graph():
    base = ROOT / "tools"
    modules = {}
    for p in sorted((base / "pleat").rglob("*.py")):
        name = ".".join(p.relative_to(base).with_suffix("").parts)
        modules[name[: -len(".__init__")] if name.endswith(".__init__") else name] = p
    graph, why = {m: set() for m in modules}, {}

    def known(name):
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name

    for module, path in modules.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for n in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets = []
            if isinstance(n, ast.Import):
                targets = [a.name for a in n.names]
            elif isinstance(n, ast.ImportFrom):
                if n.level:
                    parts = package.split(".")
                    parts = parts[: len(parts) - (n.level - 1)]
                    source = ".".join(parts + ([n.module] if n.module else []))
                else:
                    source = n.module or ""
                targets = [f"{source}.{a.name}" if f"{source}.{a.name}" in modules else source for a in n.names]
            for t in targets:
                t = known(t)
                if t and t != module:
                    graph[module].add(t)
                    why.setdefault((module, t), f"line {n.lineno}")
    return graph, why


def _cycles(graph, why):
    problems = []
    for component in strongly_connected(graph):
        if len(component) < 2:
            continue
        edges = [f"    {a} -> {b} ({why[(a, b)]})" for a in sorted(component) for b in sorted(graph[a] & component)]
        problems.append("a circle of " + ", ".join(sorted(component)) + ":\n" + "\n".join(edges))
    return problems


def test_sdk_src_has_no_circles():
    graph, why = c_graph("sdk/src")
    # the graph sees what it should (a broken pattern would find no edges and pass for nothing)
    assert "sdk/src/core/context" in graph["sdk/src/asset/asset"]
    assert "sdk/src/instance/instance_step" in graph["sdk/src/step/step"]
    assert "sdk/src/core/core" in graph["sdk/src/asset/asset"]           # an include from another layer's folder
    assert "sdk/src/jobs/mlp" in graph["sdk/src/kernels/cpu_dispatch"]   # a function pointer in the kernel table
    assert not _cycles(graph, why), "\n".join(_cycles(graph, why))


def test_samples_have_no_circles():
    graph, why = c_graph("samples")
    assert "samples/render/render_mesh" in graph["samples/render/render_crowd"]
    assert not _cycles(graph, why), "\n".join(_cycles(graph, why))


def test_tools_have_no_circles():
    graph, why = python_graph()
    assert "pleat.train.distill" in graph["pleat.train.simsup"]
    assert "pleat.motion.loaders" in graph["pleat.sim.scene"]       # a function-level import
    assert not _cycles(graph, why), "\n".join(_cycles(graph, why))


def test_a_new_circle_is_found():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert [sorted(c) for c in strongly_connected(graph) if len(c) > 1] == [["a", "b", "c"]]
    assert len(_cycles(graph, {("a", "b"): "x", ("b", "c"): "y", ("c", "a"): "z"})) == 1
