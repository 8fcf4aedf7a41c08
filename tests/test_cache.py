"""Run cache: keys, reuse, grouping, entries written one by one, and a run killed mid-way."""

import json
import signal
import subprocess
import sys
import types
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from commands import command_environment, wait_for_line
from roughfriction.case import FemCase, Loading, SolverOptions
from roughfriction.errors import InputError
from roughfriction.geometry.surface import Surface
from roughfriction.solver.progress import StepCut
from roughfriction.solver.results import FemResult, StepRecord
from roughfriction.studies import cache
from roughfriction.studies.cache import (
    PHYSICS_MODULES,
    SOLVER_OUTPUT_MODULES,
    cached_results,
    entry_path,
    finished_entry,
    physics_sources,
    physics_version,
    run_key,
)

ROOT = Path(__file__).resolve().parent.parent
PHYSICS = physics_version()


def rough_case(load=0.155, normal_only=False, seed=3, name="G-test", **solver):
    heights = np.random.default_rng(seed).normal(0.0, 0.1e-6, (8, 8))
    return FemCase(Surface(heights, 1e-6, name), Loading(load, normal_only),
                   solver=SolverOptions(**solver))


# --- keys ------------------------------------------------------------------------------------

def test_key_is_the_same_in_another_process():
    code = ("import sys; sys.path.insert(0, 'tests'); from test_cache import rough_case; "
            "from roughfriction.studies.cache import run_key, physics_version; "
            "print(run_key(rough_case(), physics_version()))")
    other = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                           text=True, check=True).stdout.strip()
    assert other == run_key(rough_case(), PHYSICS)
    assert len(other) == 64


@pytest.mark.parametrize("changed", [
    rough_case(load=0.156),
    rough_case(normal_only=True),
    rough_case(seed=4),
    rough_case(penalty=11.0),
    rough_case(max_steps=299),
])
def test_key_changes_with_what_determines_the_run(changed):
    assert run_key(changed, PHYSICS) != run_key(rough_case(), PHYSICS)


def test_key_changes_with_one_height():
    case = rough_case()
    heights = case.surface.heights.copy()
    heights[3, 4] += 1e-12
    changed = replace(case, surface=Surface(heights, 1e-6, case.surface.name))
    assert run_key(changed, PHYSICS) != run_key(case, PHYSICS)


def copy_physics_sources(destination: Path) -> dict[str, Path]:
    copies = {}
    for name, path in physics_sources().items():
        copies[name] = destination / f"{name}.py"
        copies[name].write_bytes(path.read_bytes())
    return copies


def test_every_solver_module_is_declared_physics_or_output():
    import pkgutil

    import roughfriction.solver

    modules = {f"roughfriction.solver.{info.name}"
               for info in pkgutil.iter_modules(roughfriction.solver.__path__)}
    declared = set(PHYSICS_MODULES) | set(SOLVER_OUTPUT_MODULES)
    assert modules <= declared, f"classify {sorted(modules - declared)} in studies/cache.py"


def test_every_module_a_physics_module_imports_is_physics_or_declared_output():
    import ast

    from roughfriction.studies.cache import OUTPUT_IMPORTS

    imported = set()
    for source in physics_sources().values():
        for node in ast.walk(ast.parse(source.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("roughfriction"):
                imported.add(node.module)
            elif isinstance(node, ast.Import):
                imported |= {alias.name for alias in node.names
                             if alias.name.startswith("roughfriction")}
    declared = set(PHYSICS_MODULES) | set(SOLVER_OUTPUT_MODULES) | set(OUTPUT_IMPORTS)
    assert imported <= declared, f"classify {sorted(imported - declared)} in studies/cache.py"


def test_physics_version_follows_the_physics_sources(tmp_path):
    sources = physics_sources()
    assert {"roughfriction.solver.equilibrium", "roughfriction.solver.contact",
            "roughfriction.solver.run", "roughfriction.geometry.mesh",
            "roughfriction.geometry.surface", "roughfriction.material"} <= set(sources)
    assert not set(sources) & {"roughfriction.studies.cache", "roughfriction.scripts.fem",
                               "roughfriction.studies.post", "roughfriction.geometry.readers",
                               "roughfriction.solver.fields", "roughfriction.studies.results_file"}
    copies = copy_physics_sources(tmp_path)
    assert physics_version(copies) == PHYSICS  # contents, not place or git
    contact = copies["roughfriction.solver.contact"]
    source = contact.read_text()
    contact.write_text(source.replace('"""', '"""Reworded. ', 1) + "\n# a comment\n")
    assert physics_version(copies) == PHYSICS  # documentation only: the runs stay valid
    contact.write_text(source + "\nEXTRA_CONSTANT = 1\n")
    changed = physics_version(copies)
    assert changed != PHYSICS
    assert run_key(rough_case(), changed) != run_key(rough_case(), PHYSICS)


def test_the_physics_does_no_file_output_or_provenance():
    """Writing results and asking git for the revision (studies/results_file.py) are outside
    the physics key: changing the writer keeps the cached runs."""
    for name, path in physics_sources().items():
        code = path.read_text()
        for io in ("import h5py", "import subprocess", "git"):
            assert io not in code, f"{name} holds output or provenance ({io!r})"


# --- reuse and grouping, with a stand-in for the FEM -----------------------------------------

def synthetic_run(case: FemCase):
    """What run_loads returns for ``case``, without the FEM: preload to F_n (and a slide)."""
    fn = case.normal_force
    record = {"slide": 0.0, "flat_height": 1e-7, "area_ratio": 0.25, "contact_nodes": 16,
              "contact_patches": 4, "slipping_nodes": 0, "plastic_volume_fraction": 0.0,
              "newton_iterations": 3, "krylov_iterations": 0, "wall_s": 0.1}
    records = [StepRecord("normal", fn, 0.0, **record)]
    if not case.loading.normal_only:
        records.append(StepRecord("tangential", fn, 0.5 * fn,
                                  **{**record, "slide": 1e-8, "slipping_nodes": 16}))
    result = FemResult(records, True, "", case.loading.normal_only, {"total_s": 0.2},
                       {"ranks": 1})
    return types.SimpleNamespace(result=result, maps={"contact_normal": np.eye(8, dtype=bool)},
                                 equilibrium=types.SimpleNamespace(destroy=lambda: None))


class FakeFem:
    """Stands in for solver.run: records the run_loads calls, and what was in the cache
    directory when each run started."""

    def __init__(self, directory: Path, fail_at=None):
        self.directory, self.fail_at = directory, fail_at
        self.calls, self.entries_at_start = [], []
        self.stalls, self.stalls_alone = set(), False  # (name, load): the run does not converge
        self.refused = set()  # surface names whose mesh is refused before any run starts

    def run_loads(self, case, loads, comm, progress=None, xdmf_directory=None, finished=None):
        self.calls.append((case.surface.name, case.loading.normal_only, list(loads)))
        if case.surface.name in self.refused:
            raise InputError(f"{case.surface.name}: 3 inverted cells")
        runs = []
        for index, load in enumerate(loads):
            self.entries_at_start.append(len(list(self.directory.glob("*.h5"))))
            if (case.surface.name, load) == self.fail_at:
                raise RuntimeError("killed")
            fem_run = synthetic_run(replace(case, loading=Loading(load,
                                                                  case.loading.normal_only)))
            progress(fem_run.result.records[0])
            if (case.surface.name, load) in self.stalls and (len(loads) > 1
                                                             or self.stalls_alone):
                fem_run.result = replace(fem_run.result, converged=False,
                                         message=f"stalled at F* = {load}")
            finished(index, fem_run)
            runs.append(fem_run)
        return runs


@pytest.fixture
def fake_fem(tmp_path, monkeypatch):
    fake = FakeFem(tmp_path)
    module = types.ModuleType("roughfriction.solver.run")
    module.run_loads = fake.run_loads
    monkeypatch.setitem(sys.modules, "roughfriction.solver.run", module)
    return fake


def comm_self():
    from mpi4py import MPI

    return MPI.COMM_SELF


def fill(cases, directory, lines=None):
    return cached_results(cases, comm_self(), (lines if lines is not None else []).append,
                          directory)


def test_missing_runs_are_grouped_by_all_but_the_load(fake_fem, tmp_path):
    from roughfriction.studies.post import read_run

    cases = [rough_case(0.3), rough_case(0.155), rough_case(0.3), rough_case(0.155, True),
             rough_case(0.155, seed=5, name="other")]
    lines = []
    paths = fill(cases, tmp_path, lines)
    assert fake_fem.calls == [("G-test", False, [0.155, 0.3]), ("G-test", True, [0.155]),
                              ("other", False, [0.155])]
    assert fake_fem.entries_at_start == [0, 1, 2, 3]  # each entry written as its run ends
    assert paths[0] == paths[2] and len(set(paths)) == 4
    for case, path in zip(cases, paths, strict=True):
        assert path == entry_path(tmp_path, case, PHYSICS)
        entry = read_run(path)
        assert entry.load_star == case.loading.load_star
        assert entry.inputs == case.inputs()
    assert sum("converged" in line and "runs," in line for line in lines) == 4  # progress bar
    assert lines[-6].split()[:3] == ["surface", "N", "F*"]  # the table, one row per case
    assert all(line.rstrip().endswith("computed") for line in lines[-5:])


def test_finished_entries_are_reused_without_recomputation(fake_fem, tmp_path):
    cases = [rough_case(0.155), rough_case(0.3)]
    first = fill(cases, tmp_path)
    lines = []
    assert fill(cases, tmp_path, lines) == first
    assert len(fake_fem.calls) == 1
    assert all(line.rstrip().endswith("cache") for line in lines[-2:])


def test_normal_only_case_is_answered_by_the_sliding_run(fake_fem, tmp_path):
    sliding = fill([rough_case(0.155)], tmp_path)
    assert fill([rough_case(0.155, normal_only=True)], tmp_path) == sliding
    assert len(fake_fem.calls) == 1
    # ...but a sliding case is not answered by a normal-only run.
    fill([rough_case(0.3, normal_only=True)], tmp_path)
    fill([rough_case(0.3)], tmp_path)
    assert [call[1:] for call in fake_fem.calls[1:]] == [(True, [0.3]), (False, [0.3])]


def test_temporary_files_are_not_finished_entries(fake_fem, tmp_path):
    case = rough_case()
    final = entry_path(tmp_path, case, PHYSICS)
    leftover = final.with_name(f".{final.name}.12345.tmp")
    leftover.write_bytes(b"\x89HDF\r\n half-written")
    assert finished_entry(tmp_path, case, PHYSICS) is None
    assert fill([case], tmp_path) == [final]
    assert fake_fem.calls == [("G-test", False, [0.155])]


def test_a_failure_keeps_the_runs_finished_before_it(fake_fem, tmp_path):
    cases = [rough_case(0.155), rough_case(0.3), rough_case(0.5)]
    fake_fem.fail_at = ("G-test", 0.3)
    with pytest.raises(RuntimeError, match="killed"):
        fill(cases, tmp_path)
    assert [path.name for path in tmp_path.glob("*.h5")] == \
        [entry_path(tmp_path, cases[0], PHYSICS).name]
    fake_fem.fail_at = None
    fill(cases, tmp_path)
    assert fake_fem.calls[-1] == ("G-test", False, [0.3, 0.5])  # only what was missing


def test_a_group_that_cannot_start_does_not_stop_the_others(fake_fem, tmp_path):
    from benchmarks.batch import compute_batch

    cases = [rough_case(0.155, name="bad"), rough_case(0.155), rough_case(0.3, name="bad"),
             rough_case(0.3)]
    fake_fem.refused = {"bad"}
    lines = []
    with pytest.raises(cache.RunsNotStarted, match=r"^2 run\(s\) could not start.*bad N=8 "
                       r"F\*=0.155: bad: 3 inverted cells; bad N=8 F\*=0.3: bad") as raised:
        fill(cases, tmp_path, lines)
    assert fake_fem.calls == [("bad", False, [0.155, 0.3]), ("G-test", False, [0.155, 0.3])]
    assert raised.value.paths == [entry_path(tmp_path, case, PHYSICS) for case in cases]
    assert set(raised.value.reasons) == {raised.value.paths[0], raised.value.paths[2]}
    assert [path.exists() for path in raised.value.paths] == [False, True, False, True]
    assert sum("could not start: bad: 3 inverted cells" in line for line in lines) == 2
    assert "4/4 runs" in lines[-6]  # the refused runs count in the progress bar
    assert [line.split()[-1] for line in lines[-4:]] == ["start", "computed", "start",
                                                          "computed"]
    # a benchmark batch records the refusal per case and goes on
    results = compute_batch(cases, comm_self(), tmp_path, lambda line: None)
    assert [result.error for result in results] == ["bad: 3 inverted cells", "",
                                                    "bad: 3 inverted cells", ""]
    assert [result.path for result in results[1::2]] == raised.value.paths[1::2]


def test_a_run_that_fails_on_the_shared_path_is_run_again_alone(fake_fem, tmp_path):
    from roughfriction.studies.post import read_run

    cases = [rough_case(0.155), rough_case(0.3), rough_case(0.5)]
    fake_fem.stalls = {("G-test", 0.3)}
    lines = []
    paths = fill(cases, tmp_path, lines)
    assert fake_fem.calls == [("G-test", False, [0.155, 0.3, 0.5]), ("G-test", False, [0.3])]
    retried = read_run(paths[1])
    assert retried.converged and retried.load_star == 0.3
    assert retried.note.startswith("computed alone") and "stalled at F* = 0.3" in retried.note
    assert all(read_run(path).note == "" for path in (paths[0], paths[2]))
    assert any("running it alone" in line for line in lines)
    assert sum("runs," in line for line in lines) == 4 and "3/3 runs" in lines[-5]
    assert lines[-2].rstrip().endswith("computed (alone: shared path failed)")
    # served from the cache afterwards, note and all
    assert fill(cases, tmp_path) == paths and len(fake_fem.calls) == 2


def test_a_run_that_fails_alone_too_keeps_its_shared_entry(fake_fem, tmp_path):
    from roughfriction.studies.post import read_run

    fake_fem.stalls, fake_fem.stalls_alone = {("G-test", 0.3)}, True
    paths = fill([rough_case(0.155), rough_case(0.3)], tmp_path)
    assert len(fake_fem.calls) == 2
    failed = read_run(paths[1])
    assert not failed.converged and failed.note == ""
    assert failed.message == "stalled at F* = 0.3"


def test_the_first_run_of_a_group_is_not_run_again(fake_fem, tmp_path):
    fake_fem.stalls, fake_fem.stalls_alone = {("G-test", 0.155)}, True
    fill([rough_case(0.155), rough_case(0.3)], tmp_path)
    assert len(fake_fem.calls) == 1  # its path is already its own


def test_the_runs_of_a_group_are_released_once_written(fake_fem, tmp_path, monkeypatch):
    released = []
    monkeypatch.setattr(cache, "release", released.append)
    fill([rough_case(0.155), rough_case(0.3)], tmp_path)
    assert len(released) == 1  # one group, released after both entries were written
    assert [run.result.records[-1].normal_force for run in released[0]] == [
        rough_case(load).normal_force for load in (0.155, 0.3)]


def resident_megabytes() -> float:
    """VmRSS of this process [MB]."""
    status = Path("/proc/self/status").read_text()
    return int(next(line for line in status.splitlines() if line.startswith("VmRSS")).split()[1]
               ) / 1024


def reachable_petsc_objects(root) -> list:
    """Every PETSc object reachable from ``root`` through lists, tuples, dicts and the
    attributes of roughfriction's own objects."""
    from petsc4py import PETSc

    seen, pending, found = set(), [root], []
    while pending:
        item = pending.pop()
        if id(item) in seen:
            continue
        seen.add(id(item))
        if isinstance(item, PETSc.Object):
            found.append(item)
        elif isinstance(item, (list, tuple)):
            pending.extend(item)
        elif isinstance(item, dict):
            pending.extend(item.values())
        elif type(item).__module__.startswith("roughfriction.") and hasattr(item, "__dict__"):
            pending.extend(vars(item).values())
    return found


@pytest.mark.fem
def test_released_runs_leave_no_memory_behind():
    """Without the release each of these runs leaves ~6 MB behind (petsc4py 3.18 does not free
    PETSc objects that reference each other); the model's destroy() frees every PETSc object
    the run holds."""
    from roughfriction.geometry.generate import builtin_surface
    from roughfriction.geometry.surface import surface_on_fem_grid
    from roughfriction.solver.run import run

    case = FemCase(surface_on_fem_grid(builtin_surface("G5"), 8), Loading(0.155))
    resident = []
    for _ in range(5):
        fem_run = run(case, comm_self(), progress=lambda record: None)
        held = reachable_petsc_objects(fem_run)
        assert len(held) > 10
        cache.release([fem_run])
        assert [item for item in held if item.handle != 0] == []  # all destroyed
        del fem_run, held
        resident.append(resident_megabytes())
    assert resident[-1] - resident[1] < 4.0  # the first run also fills caches


def test_cache_directory_from_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(cache.RUNS_VARIABLE, str(tmp_path))
    assert cache.runs_directory() == tmp_path
    assert cache.runs_directory(tmp_path / "x") == tmp_path / "x"
    monkeypatch.delenv(cache.RUNS_VARIABLE)
    assert cache.runs_directory() == Path("results/runs")


def test_progress_lines_name_the_run_and_the_ratio():
    lines = []
    reporter = cache.RunReporter(2, lines.append)
    reporter.begin(rough_case(0.155))
    record = StepRecord("tangential", 2.0, 0.5, 1e-8, 0.0, 0.2, 3, 1, 0, 0.1, 4, 20, 1.0)
    reporter.step(record)
    reporter.step(StepCut("tangential", 15, 1e-2, "residual not finite"))
    reporter.finished({"converged": True, "steps": 9, "newton_iterations": 40, "mu_s": 0.75,
                       "wall_s": 12.0})
    assert lines[0] == ("[1/2] G-test N=8 F*=0.155: step 1 tangential Ft/Fn=0.2500 newton 4 "
                        "(4 in run)")
    assert lines[1].endswith("sliding step retried at a smaller size: residual not finite "
                             "(Newton 15 its, residual 1.00e-02 F_n)")
    assert "mu_s=0.7500" in lines[2] and "1/2 runs" in lines[2] and "left" in lines[2]
    assert "|" + "#" * 10 + "." * 10 + "|" in lines[2]


# --- real FEM runs ----------------------------------------------------------------------------

@pytest.mark.fem
def test_a_killed_run_leaves_no_entry_and_a_rerun_completes(tmp_path):
    from roughfriction.geometry.generate import builtin_surface
    from roughfriction.geometry.surface import surface_on_fem_grid
    from roughfriction.studies.post import read_run

    command = [sys.executable, "-m", "roughfriction.scripts.cli", "runs", "G5", "--load", "0.155",
               "--n", "8", "--directory", str(tmp_path), "--json"]
    process = subprocess.Popen(command, cwd=ROOT, env=command_environment(), text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        wait_for_line(process, ": step 1 normal", 120)  # it is computing
        assert process.poll() is None
        process.send_signal(signal.SIGKILL)
        assert process.wait(30) == -signal.SIGKILL
    finally:
        if process.poll() is None:
            process.kill()
    assert not list(tmp_path.glob("*.h5"))  # nothing under a final name

    done = subprocess.run(command, cwd=ROOT, env=command_environment(), text=True,
                          capture_output=True, timeout=300)
    assert done.returncode == 0, done.stderr
    case = FemCase(surface_on_fem_grid(builtin_surface("G5"), 8), Loading(0.155))
    path = entry_path(tmp_path, case, PHYSICS)
    table = json.loads(done.stdout)["runs"]
    assert table["file"] == [str(path)]
    entry = read_run(path)
    assert entry.converged and entry.summary["mu_s"] > 0
    assert entry.maps["surface_heights"].shape == (8, 8)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left
    # the entry is the case of its key, run to inception, and the command printed its numbers
    assert entry.inputs == case.inputs()
    np.testing.assert_array_equal(entry.maps["surface_heights"], case.surface.heights)
    steps = entry.steps
    assert steps["phase"][-1] == "tangential"
    assert entry.summary["mu_s"] == pytest.approx(steps["tangential_force"][-1]
                                                  / steps["normal_force"][-1], rel=1e-12)
    assert table["mu_s"] == [entry.summary["mu_s"]]
    assert table["A_r/A_n"] == [entry.summary["area_ratio_normal"]]


@pytest.mark.mpi
@pytest.mark.fem
def test_an_entry_computed_on_two_ranks_serves_one_rank(tmp_path, monkeypatch):
    """Every rank computes, rank 0 writes; the key has no rank count, so a serial request
    finds the two-rank entry."""
    from mpi4py import MPI
    from roughfriction.studies.post import read_run

    comm = MPI.COMM_WORLD
    assert comm.size == 2, "run under mpirun -n 2"
    directory = Path(comm.bcast(str(tmp_path), root=0))
    case = rough_case(0.155)
    (path,) = cached_results([case], comm, lambda line: None, directory)
    assert path == entry_path(directory, case, PHYSICS)
    if comm.rank == 0:
        entry = read_run(path)
        assert entry.sizes["ranks"] == 2
        assert entry.inputs == case.inputs() and entry.converged
        assert entry.summary["Fn"] == pytest.approx(0.155 * (8e-6) ** 2 * case.material.Sy,
                                                  rel=1e-9)  # Eq. 10
        module = types.ModuleType("roughfriction.solver.run")
        module.run_loads = lambda *args, **kwargs: pytest.fail("recomputed")
        monkeypatch.setitem(sys.modules, "roughfriction.solver.run", module)
        assert cached_results([case], MPI.COMM_SELF, lambda line: None, directory) == [path]
    comm.barrier()


def test_cpu_share_is_near_one_while_computing_and_near_zero_while_waiting():
    import time

    from mpi4py import MPI
    from roughfriction.studies.cache import CpuShare

    share = CpuShare(MPI.COMM_SELF)
    end = time.perf_counter() + 0.3
    while time.perf_counter() < end:
        pass
    busy = share.take()
    time.sleep(0.3)
    idle = share.take()
    assert idle < 0.1 and busy > 0.3  # a busy loop keeps a core even when others share it
