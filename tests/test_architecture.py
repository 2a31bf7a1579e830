"""The module graph of render/ and train/ (docs/architecture.md): no import cycle, and
dependencies between sub-packages pointing one way, in the documented order.

Imports are read from the source with ``ast``, those inside functions included (a lazy import
still makes a cycle, only a later one), so the test needs neither Mitsuba nor Ray.
"""

import ast

from tests.conftest import REPO

PACKAGES = ("render", "train")
ORDER = {
    "render": ("common", "mitsuba_reference", "materials", ("dataset", "torch_renderer"), "cli"),
    "train": ("networks", "data", "training", "estimation", "evaluation",
              "brdf_validation", "cli"),
}
"""Each package's sub-packages in dependency order (docs/architecture.md): a module may import
only from its own sub-package and those before it (a tuple is one rank)."""
TRAIN_USES_RENDER = ("render.common", "render.materials", "render.torch_renderer",
                     "render.mitsuba_reference.scene_file")
"""What train/ may import of render/ (scene_file writes a scene without importing Mitsuba)."""


def project_modules():
    """{dotted module name: source file} of every module of PACKAGES."""
    modules = {}
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            parts = path.relative_to(REPO).with_suffix("").parts
            modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def imported_names(path, module):
    """Dotted names that the file of ``module`` imports, anywhere in it; ``from a import b``
    gives ``a.b`` (b may be a module) and ``a`` (or b is a name defined in a)."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from the package, one level up per extra dot
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            yield base
            yield from (f"{base}.{alias.name}" for alias in node.names)


def import_graph():
    """{module: set of project modules it imports}; a name outside the project's modules
    counts as its longest prefix that is one (``render.x.Name`` -> ``render.x``)."""
    modules = project_modules()
    graph = {}
    for module, path in modules.items():
        edges = set()
        for name in imported_names(path, module):
            while name and name not in modules:
                name = name.rpartition(".")[0]
            if name and name != module:
                edges.add(name)
        graph[module] = edges
    return graph


def find_cycle(graph):
    """One cycle as a list of modules (first repeated at the end), or None."""
    state = {}  # module -> "open" while on the search path, "done" once fully explored
    path = []

    def visit(module):
        state[module] = "open"
        path.append(module)
        for target in sorted(graph[module]):
            if state.get(target) == "open":
                return path[path.index(target):] + [target]
            if target not in state:
                cycle = visit(target)
                if cycle:
                    return cycle
        path.pop()
        state[module] = "done"
        return None

    for module in sorted(graph):
        if module not in state:
            cycle = visit(module)
            if cycle:
                return cycle
    return None


def rank(module):
    """(package, rank of the module's sub-package in ORDER); the package's own modules (its
    ``__init__``) rank first."""
    package, _, rest = module.partition(".")
    sub = rest.partition(".")[0]
    for position, entry in enumerate(ORDER[package]):
        if sub == entry or (isinstance(entry, tuple) and sub in entry):
            return package, position
    assert not sub, f"{module}: sub-package '{sub}' is not in ORDER (tests/test_architecture.py)"
    return package, -1


def order_violations(graph):
    """'a -> b' for each import against ORDER or TRAIN_USES_RENDER."""
    violations = []
    for module, targets in graph.items():
        for target in targets:
            (package, position), (target_package, target_position) = rank(module), rank(target)
            if package == target_package:
                if target_position > position:
                    violations.append(f"{module} -> {target}")
            elif package == "render" or not target.startswith(TRAIN_USES_RENDER):
                violations.append(f"{module} -> {target}")
    return sorted(violations)


def test_the_graph_sees_package_and_lazy_imports():
    graph = import_graph()
    assert "render.common.errors" in graph["train.networks.checkpoints"]
    # render-dataset --ray: a function-level import of the Ray runner
    assert "render.dataset.ray_runner" in graph["render.dataset.generator"]
    # ``from render.mitsuba_reference import ward_bsdf`` names a module
    assert "render.mitsuba_reference.ward_bsdf" in graph["render.mitsuba_reference.loading"]


def test_find_cycle_reports_the_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert find_cycle(graph) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycle_between_project_modules():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_order_violations_are_found():
    graph = {"train.data.photos": {"train.training.losses"},
             "train.training.losses": {"train.data.photos", "render.dataset.tasks"},
             "render.common.images": {"train.networks.model_files"}}
    assert order_violations(graph) == ["render.common.images -> train.networks.model_files",
                                       "train.data.photos -> train.training.losses",
                                       "train.training.losses -> render.dataset.tasks"]


def test_every_sub_package_is_in_the_order_and_dependencies_point_one_way():
    graph = import_graph()
    for module in graph:
        rank(module)
    assert order_violations(graph) == []
    for package, order in ORDER.items():  # and the order names no package that is gone
        for name in (n for entry in order for n in (entry if isinstance(entry, tuple)
                                                    else (entry,))):
            assert (REPO / package / name / "__init__.py").is_file(), f"{package}/{name}"
