"""The shape the code keeps (docs: the structure of pardem): small modules, jitted functions
without long positional argument lists, MPI reached only from pardem/parallel/, and a serial run
that never loads MPI."""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted(p for package in ("pardem", "averaging") for p in (ROOT / package).rglob("*.py"))
MAX_LINES = 350
MAX_SCRIPT_LINES = 400
MAX_ARGS = 12


def _jitted(node: ast.FunctionDef) -> bool:
    for d in node.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        name = ast.unparse(target)
        if name.split(".")[-1] in ("njit", "jit", "overload", "intrinsic"):
            return True
    return False


def test_modules_are_small():
    long = {str(p.relative_to(ROOT)): n for p in SOURCES
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"


def test_run_scripts_are_small():
    long = {str(p.relative_to(ROOT)): n for p in sorted((ROOT / "run_scripts").rglob("*.py"))
            if (n := len(p.read_text().splitlines())) > MAX_SCRIPT_LINES}
    assert not long, f"scripts over {MAX_SCRIPT_LINES} lines: {long}"


def test_no_jitted_function_takes_more_than_twelve_positional_arguments():
    found = []
    for path in SOURCES:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and _jitted(node):
                n = len(node.args.posonlyargs) + len(node.args.args)
                if n > MAX_ARGS:
                    found.append(f"{path.relative_to(ROOT)}:{node.name} ({n})")
    assert not found, found


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _module_imports(path: Path, modules: set[str]) -> set[str]:
    """The project modules ``path`` imports at module level (``from . import sub`` imports
    the submodule, not its package)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name in modules}
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")[:len(package.split(".")) - node.level + 1] if node.level \
                else []
            target = ".".join(base + ([node.module] if node.module else []))
            subs = {f"{target}.{a.name}" for a in node.names} & modules
            found |= subs if subs else ({target} & modules)
    return found - {name}


def test_no_import_circle_among_modules():
    """Module-level imports form no cycle: a module's dependencies can be read before it."""
    modules = {_module_name(p) for p in SOURCES}
    graph = {_module_name(p): _module_imports(p, modules) for p in SOURCES}
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(m: str, path: list[str]) -> list[str] | None:
        state[m] = 1
        for d in sorted(graph[m]):
            if state.get(d) == 1:
                return path + [m, d]
            if d not in state and (cycle := visit(d, path + [m])):
                return cycle
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            cycle = visit(m, [])
            assert cycle is None, " -> ".join(cycle[cycle.index(cycle[-1]):])


def test_averaging_reaches_pardem_only_through_sampling():
    """Every import of pardem in averaging/ (at any level) is of pardem.sampling: the one
    interface between a run and the fields built from it."""
    found = []
    for path in sorted((ROOT / "averaging").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level
                     else [])
            found += [f"{path.name}: {n}" for n in names
                      if n.split(".")[0] == "pardem" and n != "pardem.sampling"]
    assert not found, f"averaging/ imports pardem's internals: {found}"


def _nodes_outside_parallel():
    """(path, node) of every syntax node of the modules outside pardem/parallel/."""
    parallel = ROOT / "pardem" / "parallel"
    for path in SOURCES:
        if parallel not in path.parents:
            for node in ast.walk(ast.parse(path.read_text())):
                yield path, node


def test_mpi_is_imported_only_under_pardem_parallel():
    found = []
    for path, node in _nodes_outside_parallel():
        names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                 [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
        if any(n.split(".")[0] == "mpi4py" or n.endswith("parallel.native")
               or n.endswith("parallel.halo") or n.endswith("parallel.comm") for n in names):
            found.append(str(path.relative_to(ROOT)))
    assert not found, f"MPI reached outside pardem/parallel: {found}"


MPI_METHODS = {"Barrier", "Get_rank", "Get_size", "Abort", "Allreduce", "Bcast", "Split_type",
               "Free", "Isend", "Irecv", "Waitall"}


def test_communicators_are_used_only_under_pardem_parallel():
    """Outside pardem/parallel/ no module calls a communicator's methods (mpi4py's capitalised
    ones, or bcast/allreduce on a ``comm``): the front goes through parallel's helpers."""
    found = []
    for path, node in _nodes_outside_parallel():
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
            continue
        owner = ast.unparse(node.func.value)
        if node.func.attr in MPI_METHODS or (
                node.func.attr in ("bcast", "allreduce", "gather")
                and (owner == "comm" or owner.endswith(".comm"))):
            found.append(f"{path.relative_to(ROOT)}:{node.lineno} {owner}.{node.func.attr}")
    assert not found, found


def test_a_serial_run_loads_no_mpi(tmp_path):
    """A free scene run on one process, with output: neither mpi4py nor libmpi is loaded."""
    code = """
import sys
from pathlib import Path
sys.path.insert(0, "tests")
from helpers import dense_packing, free_scene
from pardem.simulation import Simulation
sim = Simulation(free_scene(dense_packing(4, 4)), out_dir=Path(sys.argv[1]))
sim.run(end=0.01, progress=False)
maps = Path("/proc/self/maps").read_text()
print("mpi4py" in sys.modules, "libmpi" in maps)
"""
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "False"]


def test_the_kernel_cache_is_keyed_by_the_kernel_sources():
    """The numba cache folder's name hashes what compiled code depends on (core/jit.py): the
    modules that define kernels (the step loop, the contact law, the averaging's sums) and
    those they import (the particle kinds' constants), found from wherever jit.py lies in the
    package; not the front end."""
    from pardem.core.jit import kernel_sources

    found = {p.relative_to(ROOT).as_posix() for p in kernel_sources()}
    assert {"pardem/core/step.py", "pardem/contact/model.py", "averaging/sums.py",
            "pardem/core/static.py", "pardem/boundaries/protocol.py"} <= found
    for front in ("pardem/cli.py", "pardem/simulation.py", "pardem/builder.py",
                  "pardem/input/scene.py", "pardem/output/progress.py", "averaging/report.py"):
        assert front not in found


def test_an_upgrade_that_changes_no_kernel_keeps_the_cache_folder(tmp_path):
    """In a copy of the sources, editing the CLI, the run loop or a scene table's docs keeps
    the cache key (the compiled kernels are found again); editing a comment of the force loop,
    or a constant the kernels import, gives a new one."""
    from pardem.core.jit import kernel_key

    for package in ("pardem", "averaging"):
        shutil.copytree(ROOT / package, tmp_path / package,
                        ignore=shutil.ignore_patterns("__pycache__"))
    key = kernel_key(tmp_path)
    for front in ("pardem/cli.py", "pardem/simulation.py", "pardem/input/scene.py"):
        with open(tmp_path / front, "a") as f:
            f.write("\n# an upgrade of the front end\n")
        assert kernel_key(tmp_path) == key, front
    for kernel in ("pardem/core/forces.py", "pardem/boundaries/protocol.py"):
        with open(tmp_path / kernel, "a") as f:
            f.write("\n# an edit of what kernels read\n")
        assert kernel_key(tmp_path) != key, kernel
        key = kernel_key(tmp_path)