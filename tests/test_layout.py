"""The package map of the README ("Layout") holds for the code: each package
imports only what its row allows, no two modules import each other (no
import circle of any length, lazy imports inside functions included), no
module imports another module's private (underscore) names, and every
public function, class and method has a docstring. Checked on the
installed sources."""
import ast
import os

import pytest

import remote_trigger

ROOT = list(remote_trigger.__path__)[0]          # a namespace package
P = "remote_trigger."

#: importer prefix -> prefixes it may import (besides itself); the longest
#: matching importer prefix applies
ALLOWED = {
    "analysis": ("analysis.errors", "analysis.output"),
    "analysis.state": ("analysis.errors", "analysis.output", "analysis.state"),
    "analysis.stability": ("analysis.errors", "analysis.output", "analysis.state",
                           "analysis.stability"),
    "analysis.dynamics": ("analysis.errors", "analysis.output", "analysis.dynamics"),
    "pywrap.config": ("analysis",),
    "pywrap.errors": ("analysis", "pywrap.config", "pywrap.bindings", "pywrap.stages"),
    "pywrap.bindings": ("analysis", "pywrap.config", "pywrap.bindings"),
    "pywrap.runtime": ("analysis", "pywrap.config", "pywrap.runtime"),
    "pywrap.stages": ("analysis", "pywrap.config", "pywrap.bindings", "pywrap.runtime",
                      "pywrap.stages"),
    "pywrap.cli": ("analysis", "pywrap"),
}
#: a job may import the lower layers and the paper job (whose folder the
#: trigger map and the ensemble start from), not another job
_JOB = ("analysis", "pywrap.config", "pywrap.errors", "pywrap.bindings", "pywrap.runtime",
        "pywrap.stages", "pywrap.jobs.paper")
ALLOWED["pywrap.jobs"] = _JOB
for _job in ("paper", "trigger_map", "ensemble", "accuracy"):
    ALLOWED[f"pywrap.jobs.{_job}"] = _JOB


def modules():
    out = {}
    for top in ("analysis", "pywrap"):
        for d, _, files in os.walk(os.path.join(ROOT, top)):
            for f in files:
                if f.endswith(".py"):
                    path = os.path.join(d, f)
                    name = os.path.relpath(path, ROOT)[:-3].replace(os.sep, ".")
                    pkg = name.endswith(".__init__")
                    out[name[:-9] if pkg else name] = (path, pkg)
    return out


MODULES = modules()


def imported_from(node, base):
    """The project module (without the ``remote_trigger.`` prefix) an
    ``ast.ImportFrom`` in package ``base`` imports from; None outside the project."""
    if node.level:
        b = base
        for _ in range(node.level - 1):
            b = b.rpartition(".")[0]
        return b + ("." + node.module if node.module else "")
    if (node.module or "").startswith(P):
        return node.module[len(P):]
    return None


def imports(name):
    """Modules of the project that ``name`` imports (anywhere in its source)."""
    path, pkg = MODULES[name]
    base = name if pkg else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(open(path).read(), filename=path)):
        if isinstance(node, ast.ImportFrom):
            mod = imported_from(node, base)
            if mod is None:
                continue
            for a in node.names:
                found.add(mod + "." + a.name if mod + "." + a.name in MODULES else mod)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith(P):
                    found.add(a.name[len(P):])
    found.discard(name)
    return {m for m in found if m in MODULES}


def rule(name):
    keys = [k for k in ALLOWED if name == k or name.startswith(k + ".")]
    return max(keys, key=len) if keys else None


def allowed(importer, imported):
    key = rule(importer)
    if key is None:
        return True
    if imported == key or imported.startswith(key + "."):
        return True
    return any(imported == a or imported.startswith(a + ".") for a in ALLOWED[key])


@pytest.mark.parametrize("name", sorted(MODULES))
def test_imports_follow_the_map(name):
    bad = sorted(m for m in imports(name) if not allowed(name, m))
    assert not bad, f"{name} imports {bad} (README Layout: {rule(name)})"


def cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_circles():
    # a package imports its own modules; a module importing names from its
    # package's __init__ is the usual Python idiom, not a circle of the code
    graph = {m: {i for i in imports(m) if not m.startswith(i + ".")} for m in MODULES}
    assert not cycles(graph)


def test_the_checks_can_fail():
    assert not allowed("analysis.state.state", "analysis.stability.jacobian")
    assert not allowed("pywrap.runtime.jobfolder", "pywrap.jobs.paper")
    assert not allowed("pywrap.jobs.ensemble.job", "pywrap.jobs.trigger_map.job")
    assert allowed("pywrap.jobs.ensemble.job", "pywrap.jobs.paper.config")
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def private_imports(name, source=None):
    """The private names of *other* modules of the project that module ``name``
    uses: ``from m import _x`` (a name or a private module), and ``alias._x``
    where ``alias`` is a project module it imported. Dunder names are not
    private. Returns sorted ``(line, 'module._x')``."""
    path, pkg = MODULES[name] if name in MODULES else (None, False)
    base = name if pkg else name.rpartition(".")[0]
    tree = ast.parse(source if source is not None else open(path).read())

    def private(n):
        return n.startswith("_") and not (n.startswith("__") and n.endswith("__"))

    found, aliases = set(), {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            mod = imported_from(node, base)
            if mod is None:
                continue
            for a in node.names:
                full = mod + "." + a.name
                if full in MODULES:
                    aliases[a.asname or a.name] = full
                if private(a.name) and mod != name and full != name:
                    found.add((node.lineno, full))
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith(P) and a.asname:
                    aliases[a.asname] = a.name[len(P):]
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                and node.value.id in aliases and private(node.attr)
                and aliases[node.value.id] != name):
            found.add((node.lineno, aliases[node.value.id] + "." + node.attr))
    return sorted(found)


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_private_name_is_imported_across_modules(name):
    bad = private_imports(name)
    assert not bad, f"{name} uses private names of other modules: " + ", ".join(
        f"{what} (line {line})" for line, what in bad)


def test_the_private_name_check_can_fail():
    name = "analysis.stability.verdict"
    assert private_imports(name, "from remote_trigger.analysis.stability.sliced import _x\n") \
        == [(1, "analysis.stability.sliced._x")]
    assert private_imports(name, "from . import decision as d\nd._y\n") == \
        [(2, "analysis.stability.decision._y")]
    assert private_imports(name, "from remote_trigger.analysis.stability import verdict\n"
                                 "verdict._own\nfrom numpy import _z\n__all__ = []\n") == []


def undocumented(source):
    """Public functions, classes and methods of a module's source without a
    docstring (a property's setter, which shares its getter's, excepted)."""
    out = []
    tree = ast.parse(source)
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and not node.name.startswith("_"):
            if not ast.get_docstring(node):
                out.append(node.name)
            if isinstance(node, ast.ClassDef):
                for sub in node.body:
                    if (isinstance(sub, ast.FunctionDef) and not sub.name.startswith("_")
                            and not ast.get_docstring(sub)
                            and not any(isinstance(d, ast.Attribute) and d.attr == "setter"
                                        for d in sub.decorator_list)):
                        out.append(f"{node.name}.{sub.name}")
    return out


def test_the_docstring_check_can_fail():
    assert undocumented("def f():\n    pass\n") == ["f"]
    assert undocumented("class A:\n    '''A.'''\n    def g(self):\n        pass\n") == ["A.g"]
    assert undocumented("class A:\n    '''A.'''\n    @property\n    def p(self):\n"
                        "        '''P.'''\n    @p.setter\n    def p(self, v):\n        pass\n"
                        "def _private():\n    pass\n") == []


@pytest.mark.parametrize("name", sorted(MODULES))
def test_public_names_have_docstrings(name):
    with open(MODULES[name][0]) as fh:
        missing = undocumented(fh.read())
    assert not missing, f"{name}: no docstring: {', '.join(missing)}"
