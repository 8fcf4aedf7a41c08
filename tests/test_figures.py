"""Figures: each writes a PNG and the CSV behind it; the CSVs hold the plotted physics. Theory
figures are drawn here; FEM figures declare their runs (checked without the FEM), draw from
given runs, and one is built end to end on an 8 x 8 grid through the run cache."""

import importlib
import sys
import time
import types
from pathlib import Path

import numpy as np
import pytest
from roughfriction.case import FemCase
from roughfriction.geometry.generate import builtin_surface
from roughfriction.material import Material
from roughfriction.multiscale.friction import static_friction
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.multiscale.stacking import normal_contact
from roughfriction.scripts.figures import (
    FEM_FIGURES,
    FIGURES,
    THEORY_FIGURES,
    make_figure,
    read_table,
    write_table,
)
from roughfriction.studies.certificate import BOUNDARY_FACTOR
from roughfriction.studies.paper import ERROR_BAR_LOADS, FEM_LOAD_SWEEP

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def figure_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("figures")
    for name in THEORY_FIGURES:
        make_figure(name, directory)
    return directory


def height_map_columns(name: str) -> dict:
    """A built-in surface's heights as the long-format columns of Figs. 3-6, from the surface
    itself: x = i h, y = j h [m] in x-major order, z [m]."""
    surface = builtin_surface(name)
    i, j = np.indices((surface.n, surface.n))
    return {"x_m": (i * surface.spacing).ravel(), "y_m": (j * surface.spacing).ravel(),
            "z_m": surface.heights.ravel()}


def scale_columns(ratio: bool) -> dict:
    """Figs. 12-13 from 2L's scale decomposition: lambda_i = L / i [m] (closed form) and
    Delta_i [m], or Delta_i / lambda_i [-]."""
    surface = builtin_surface("2L")
    scales = scale_decomposition(surface)
    wavelength = surface.scan_length / np.arange(1, len(scales.amplitude) + 1)
    if ratio:
        return {"wavelength_m": wavelength, "amplitude_over_wavelength": scales.amplitude
                / wavelength}
    return {"wavelength_m": wavelength, "amplitude_m": scales.amplitude}


def theory_2l() -> tuple:
    """2L at F* = 0.5 (Figs. 17-19): the scale levels, the per-scale normal contact (Eqs.
    22-23, on its own) and the multi-scale result."""
    scales = scale_decomposition(builtin_surface("2L"))
    normal = normal_contact(scales, 0.5, Material())
    friction = static_friction(scales, 0.5, Material())
    return np.arange(1, len(scales.amplitude) + 1), normal, friction


def friction_columns(name: str) -> dict:
    """Figs. 17-19 from the theory: areas per scale; F_t / A_s,i = mu_s F* S_y / (A_s,i / A_n)
    (mu_s = F_t / F_n, F_n = F* A_n S_y); F_t / (A_n S_y) per load iteration."""
    levels, normal, friction = theory_2l()
    sliding = friction.area_ratios_sliding
    if name == "fig17":
        return {"scale_level": levels, "area_ratio_normal": normal.area_ratios,
                "area_ratio_sliding": sliding}
    if name == "fig18":
        return {"scale_level": levels, "shear_stress_Pa": friction.shear_stresses,
                "shear_on_sliding_area_Pa": friction.mu_s * 0.5 * Material().Sy / sliding}
    history = np.asarray(friction.history)
    return {"iteration": np.arange(1, len(history) + 1),
            "Ft_star": history / (friction.normal_load / 0.5)}


#: What each theory figure's CSV holds, computed without the figure's module.
THEORY_COLUMNS = {
    "fig3": lambda: height_map_columns("2L"), "fig4": lambda: height_map_columns("2L"),
    "fig5": lambda: height_map_columns("G5"), "fig6": lambda: height_map_columns("G5"),
    "fig12": lambda: scale_columns(ratio=False), "fig13": lambda: scale_columns(ratio=True),
    "fig17": lambda: friction_columns("fig17"), "fig18": lambda: friction_columns("fig18"),
    "fig19": lambda: friction_columns("fig19"),
}


@pytest.mark.parametrize("name", THEORY_FIGURES)
def test_figure_writes_png_and_csv(name, figure_dir):
    """The PNG, and the CSV holding the plotted values (10 significant digits)."""
    png = figure_dir / f"{name}.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = read_table(figure_dir / f"{name}.csv")
    assert len(table) >= 2
    expected = THEORY_COLUMNS[name]()
    assert list(table) == list(expected)
    for key, values in expected.items():
        np.testing.assert_allclose(table[key], values, rtol=1e-9, atol=0, err_msg=key)
    assert not list(figure_dir.glob(".*"))  # no temporary files left behind


def test_fig19_peak_tangential_load_is_mu_s_times_the_load(figure_dir):
    """max_j F_t^(j) / (A_n S_y) = mu_s F* (mu_s = F_t,max / F_n, F_n = F* A_n S_y), with
    mu_s of ``roughfriction multiscale 2L --load 0.5``."""
    from roughfriction.multiscale.theory import evaluate_theory

    mu_s = evaluate_theory(builtin_surface("2L"), 0.5, Material()).mu_s
    assert read_table(figure_dir / "fig19.csv")["Ft_star"].max() == pytest.approx(
        mu_s * 0.5, rel=1e-9)


#: Least width of a figure PNG for README width on a high-density screen [px] (the old: 550).
MIN_PNG_WIDTH = 1000


@pytest.mark.parametrize("name", THEORY_FIGURES)
def test_figure_pngs_are_sharp(name, figure_dir):
    from matplotlib.image import imread

    assert imread(figure_dir / f"{name}.png").shape[1] >= MIN_PNG_WIDTH


def test_fig17_sliding_area_not_below_normal(figure_dir):
    data = read_table(figure_dir / "fig17.csv")
    assert np.all(data["area_ratio_sliding"] >= data["area_ratio_normal"])
    assert data["area_ratio_sliding"][-1] > data["area_ratio_normal"][-1]  # junction growth


def test_fig18_shear_stress_rises_to_tau_c(figure_dir):
    data = read_table(figure_dir / "fig18.csv")
    assert np.all(np.diff(data["shear_stress_Pa"]) >= 0)  # assumption f'
    on_sliding_area = data["shear_on_sliding_area_Pa"]
    tau_c = Material().tau_c
    assert np.all(on_sliding_area <= tau_c * (1 + 1e-9))
    assert on_sliding_area[-1] == pytest.approx(tau_c, rel=1e-9)


def test_write_table_refuses_ragged_columns(tmp_path):
    with pytest.raises(ValueError, match="equal length"):
        write_table(tmp_path / "t.csv", {"a": np.arange(3), "b": np.arange(4)})
    assert not list(tmp_path.iterdir())


# --- FEM figures: declarations ----------------------------------------------------------------

def test_registry_lists_every_figure_script():
    scripts = {path.stem for path in (ROOT / "scripts").glob("fig[0-9]*.py")}
    assert set(FIGURES) == scripts
    assert not set(THEORY_FIGURES) & set(FEM_FIGURES)


@pytest.mark.parametrize("name", FEM_FIGURES)
def test_fem_figure_declares_its_runs(name):
    module = importlib.import_module(f"roughfriction.scripts.{name}")
    cases = module.fem_cases(8)
    # on the figure's grid, or a 2x finer mesh of it for an error bar
    assert cases and all(isinstance(case, FemCase) and case.surface.n in (8, 16)
                         for case in cases)
    assert callable(module.make)


@pytest.mark.parametrize("name", THEORY_FIGURES)
def test_theory_figure_needs_no_runs(name):
    assert not hasattr(importlib.import_module(f"roughfriction.scripts.{name}"), "fem_cases")


def test_fem_figures_share_runs():
    """Fig. 14's loads are among Figs. 26–28's, so 2L's sliding runs answer them; Figs. 10
    and 29 use exactly the runs of Figs. 9 and 21."""
    from roughfriction.scripts import fig9, fig10, fig14, fig21, fig29

    assert set(fig14.LOADS) <= set(FEM_LOAD_SWEEP)
    for one, other in ((fig9, fig10), (fig21, fig29)):
        assert [c.inputs() for c in one.fem_cases(8)] == [c.inputs() for c in other.fem_cases(8)]


#: Contact nodes and boundary nodes of every stand-in run (the certificate's resolution term).
FAKE_CONTACT = {"contact_nodes": 400, "boundary_nodes": 100}


def fake_runs(cases, mu_s):
    """Stand-ins for results files, enough for the mu_s figures."""
    return [types.SimpleNamespace(n=case.surface.n, load_star=case.loading.load_star,
                                  surface_name=case.surface.name,
                                  summary={"mu_s": mu, **FAKE_CONTACT},
                                  inputs=case.inputs(), converged=mu is not None)
            for case, mu in zip(cases, mu_s, strict=True)]


#: A FEM label for runs that failed before sliding inception.
AT_LEAST = "FEM failed before inception: $\\mu_s \\geq$"


def test_mu_vs_psi_marks_statistical_models_outside_their_range(monkeypatch):
    from roughfriction.scripts import fem_views, fig22, fig23

    # G2 failed before sliding inception, at F_t/F_n = 2.3 and rising
    monkeypatch.setattr(fem_views, "tangential_curve",
                        lambda run: {"Ft_over_Fn": np.array([0.0, 1.2, 2.3])})
    mu_fem = [0.9, None, *[0.5] * 7]
    cases = fig22.fem_cases(8)  # 9 runs on the figure's mesh, 9 on a 2x finer one (not run)
    fig, columns = fig22.make(fake_runs(cases, mu_fem + [None] * (len(cases) - 9)))
    assert np.isnan(columns["mu_fem"][1]) and columns["mu_fem"][0] == 0.9
    assert columns["mu_fem_at_least"][1] == 2.3
    assert np.isnan(np.delete(columns["mu_fem_at_least"], 1)).all()
    assert list(columns["cke_valid"]) == [psi <= 8 for psi in columns["psi"]]
    assert all(columns["let_valid"])  # psi <= 32 and F* <= 0.3
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert "CKE (Eq. 8), outside its range" in labels and "LET (Eq. 20)" in labels
    assert AT_LEAST in labels
    cases = fig23.fem_cases(8)
    fig, columns = fig23.make(fake_runs(cases, [0.9] * len(cases)))
    assert not any(columns["cke_valid"]) and not any(columns["let_valid"])  # F* = 0.62 > 0.3
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert "LET (Eq. 20)" not in labels and "LET (Eq. 20), outside its range" in labels
    assert AT_LEAST not in labels  # no failed run, no such marker


def test_mu_vs_psi_reports_the_psi_that_was_meshed():
    from roughfriction.scripts import fig22, fig26

    cases = fig22.fem_cases(32)
    runs = fake_runs(cases, [0.5] * len(cases))
    for run, case in zip(runs, cases, strict=True):
        run.maps, run.spacing = {"surface_heights": case.surface.heights}, case.surface.spacing
    fig, columns = fig22.make(runs)
    np.testing.assert_allclose(columns["psi_fem"], columns["psi"], rtol=0.03)
    assert not fig.axes[0].texts  # nothing meshed off the axis
    cases = fig26.fem_cases(32)  # the 2L stand-in, re-gridded: a smoother surface
    runs = fake_runs(cases, [0.5] * len(cases))
    for run, case in zip(runs, cases, strict=True):
        run.maps, run.spacing = {"surface_heights": case.surface.heights}, case.surface.spacing
    fig, columns = fig26.make(runs)
    fem = columns["model"] == "fem"
    assert np.all(columns["psi_fem"][fem] < 10.0) and np.isnan(columns["psi_fem"][~fem]).all()
    assert "FEM meshed ψ" in fig.axes[0].get_title()


def test_mu_vs_psi_at_low_load_shows_the_scatter_of_windows():
    """Fig. 22 runs 4 disjoint windows of each G surface besides the one nearest its psi; the
    CSV has their range, without a window that failed; Fig. 23 runs none."""
    from roughfriction.scripts import fig22, fig23

    cases = fig22.fem_cases(32)
    assert len(cases) == 9 + 9 + 9 * 4 and len(fig23.fem_cases(32)) == 9 + 9
    windows = cases[18:22]  # G1's
    assert {case.surface.name for case in windows} == {"G1"}
    assert len({case.surface.heights.tobytes() for case in windows}) == 4
    assert all(case.surface.spacing == cases[0].surface.spacing for case in windows)
    mu = [0.5] * 18 + [0.4, 0.6, None, 0.45] + [0.3] * 32
    fig, columns = fig22.make(fake_runs(cases, mu))
    assert columns["fem_windows"][0] == 3 and columns["fem_windows"][1] == 4
    assert columns["mu_fem_windows_min"][0] == 0.4 and columns["mu_fem_windows_max"][0] == 0.6
    assert list(columns["mu_fem"]) == [0.5] * 9
    assert "FEM, 4 windows on the diagonal (1x mesh)" in fig.axes[0].get_legend_handles_labels()[1]
    _, columns = fig23.make(fake_runs(fig23.fem_cases(32), [0.3] * 18))
    assert "fem_windows" not in columns


def test_mu_vs_psi_error_bars_from_a_2x_finer_mesh():
    """At every load each G surface also runs on a 2x finer mesh of the same surface: the
    figure plots that mu_s with its certificate (from |mu_2x - mu_1x| and the 2x contact);
    where the finer run failed, the figure's own run without a bar."""
    from roughfriction.geometry.surface import bilinear_refine
    from roughfriction.scripts import fig22, fig23
    from roughfriction.studies.certificate import certify

    cases = fig22.fem_cases(32)
    for coarse, fine in zip(cases[:9], cases[9:18], strict=True):
        assert fine.surface.n == 64 and fine.surface.spacing == coarse.surface.spacing / 2
        np.testing.assert_array_equal(fine.surface.heights,
                                      bilinear_refine(coarse.surface.heights, 2))
    fine_mu = [0.6, None, 0.45, *[0.5] * 6]
    coarse_mu = [0.5, 0.5, None, *[0.5] * 6]
    fig, columns = fig22.make(fake_runs(cases, coarse_mu + fine_mu + [0.3] * 36))
    np.testing.assert_allclose(columns["mu_fem"], [0.6, 0.5, 0.45, *[0.5] * 6])
    np.testing.assert_allclose(columns["mu_fem_error"][[0, 3]],
                               [certify((0.5, 0.6), 400, 100).error,
                                certify((0.5, 0.5), 400, 100).error], rtol=1e-12)
    assert columns["mu_fem_error"][3] == pytest.approx(BOUNDARY_FACTOR * 0.5 * 10 / 400)
    assert np.isnan(columns["mu_fem_error"][1:3]).all()
    assert list(columns["fem_refinement"]) == [2, 1, 2, *[2] * 6]
    np.testing.assert_array_equal(columns["mu_fem_coarse"][[0, 1]], [0.5, 0.5])
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert any("2x finer mesh" in label for label in labels)
    cases = fig23.fem_cases(32)
    _, columns = fig23.make(fake_runs(cases, [0.3] * len(cases)))
    assert np.isfinite(columns["mu_fem_error"]).all() and set(columns["fem_refinement"]) == {2}


def test_mu_vs_load_columns():
    from roughfriction.scripts import fig28

    cases = fig28.fem_cases(8)
    fig, columns = fig28.make(fake_runs(cases, [0.7] * len(cases)))
    fem = columns["model"] == "fem"
    assert list(columns["load_star"][fem]) == list(FEM_LOAD_SWEEP)
    barred = np.isin(FEM_LOAD_SWEEP, ERROR_BAR_LOADS)
    assert len(cases) == len(FEM_LOAD_SWEEP) + barred.sum()
    assert list(columns["fem_refinement"][fem]) == list(np.where(barred, 2, 1))
    np.testing.assert_allclose(columns["mu_fem_error"][fem][barred],
                               BOUNDARY_FACTOR * 0.7 * 10 / 400)
    assert np.isnan(columns["mu_fem_error"][~fem]).all()
    let = columns["model"] == "let"
    assert all((columns["note"][let] == "") == (columns["load_star"][let] <= 0.3))


def test_mu_vs_psi_reports_how_well_the_patches_are_resolved():
    """F_n / (A_s S_y) and contact cells per patch at inception, NaN without a contact area."""
    from roughfriction.scripts import fig22

    cases = fig22.fem_cases(8)[:18]  # on the figure's mesh, then on a 2x finer one
    runs = fake_runs(cases, [0.1] * 18)
    for run, case in zip(runs, cases, strict=True):
        run.spacing = case.surface.spacing
        nominal = (case.surface.n * case.surface.spacing) ** 2
        run.summary.update(Fn=0.155 * nominal * 1e9, area_ratio_sliding=0.05,
                           cells_per_patch=2.5)
    runs[17].summary["area_ratio_sliding"] = None  # G9's plotted run: the finer one
    _, columns = fig22.make(runs)
    np.testing.assert_allclose(columns["fem_pressure_over_Sy"][:8], 0.155 / 0.05)
    assert np.isnan(columns["fem_pressure_over_Sy"][8])
    assert list(columns["fem_cells_per_patch"]) == [2.5] * 9


def test_mu_vs_load_notes_a_failed_run_with_its_lower_bound(monkeypatch):
    from roughfriction.scripts import fem_views, fig28

    monkeypatch.setattr(fem_views, "tangential_curve",
                        lambda run: {"Ft_over_Fn": np.array([0.0, 0.61])})
    cases = fig28.fem_cases(8)  # 6 loads, then the same on a 2x finer mesh
    fig, columns = fig28.make(fake_runs(cases, [None] + [0.7] * 5 + [None] + [0.7] * 5))
    fem = columns["model"] == "fem"
    assert columns["note"][fem][0] == "failed before sliding inception: mu_s >= 0.61"
    assert not any(columns["note"][fem][1:])
    assert AT_LEAST in fig.axes[0].get_legend_handles_labels()[1]


# --- FEM figures: what they are about to compute ----------------------------------------------

class CacheReached(Exception):
    """Raised by a stand-in run cache instead of computing runs."""


def no_runs(monkeypatch):
    """Make the run cache raise :class:`CacheReached` instead of computing or reading runs."""
    from roughfriction.studies import cache

    def refuse(*args, **kwargs):
        raise CacheReached

    monkeypatch.setattr(cache, "cached_results", refuse)


def fake_entries(cases, directory: Path) -> set[str]:
    """Empty files at the cache entries of ``cases`` (a finished entry is a file under its
    final name); return their keys."""
    from roughfriction.studies.cache import entry_path, physics_version, run_key

    physics = physics_version()
    directory.mkdir(parents=True, exist_ok=True)
    for case in cases:
        entry_path(directory, case, physics).touch()
    return {run_key(case, physics) for case in cases}


@pytest.mark.parametrize("name", ["fig20", "fig22"])
def test_a_fem_figure_says_which_runs_it_will_compute(name, tmp_path, monkeypatch, capsys):
    """One stderr line before the runs start: how many, how many are cached, on which N."""
    from roughfriction.studies.cache import physics_version, run_key

    no_runs(monkeypatch)
    cases = importlib.import_module(f"roughfriction.scripts.{name}").fem_cases(8)
    physics = physics_version()
    needed = {run_key(case, physics) for case in cases}
    cached = fake_entries(cases[: len(cases) // 3], tmp_path / "runs")
    with pytest.raises(CacheReached):
        make_figure(name, tmp_path, n=8, runs_directory=tmp_path / "runs")
    (line,) = capsys.readouterr().err.splitlines()
    grids = " and ".join(str(n) for n in sorted({case.surface.n for case in cases}))
    assert line.startswith(f"{name}: {len(needed)} FEM runs needed (N = {grids}), "
                           f"{len(cached)} in the run cache {tmp_path / 'runs'}, computing "
                           f"{len(needed) - len(cached)} now")


def test_the_batch_of_every_fem_figure_says_which_runs_it_will_compute(tmp_path, monkeypatch,
                                                                       capsys):
    from roughfriction.scripts.figures import compute_fem_runs

    no_runs(monkeypatch)
    with pytest.raises(CacheReached):
        compute_fem_runs(n=8, runs_directory=tmp_path / "runs")
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("figure runs: ") and ", 0 in the run cache " in line


def test_a_fem_figure_with_every_run_cached_says_nothing(tmp_path, monkeypatch, capsys):
    from roughfriction.scripts import fig20

    no_runs(monkeypatch)
    fake_entries(fig20.fem_cases(8), tmp_path / "runs")
    with pytest.raises(CacheReached):
        make_figure("fig20", tmp_path, n=8, runs_directory=tmp_path / "runs")
    assert capsys.readouterr().err == ""


def test_a_theory_figure_says_nothing(tmp_path, capsys):
    make_figure("fig12", tmp_path)
    assert capsys.readouterr().err == ""


# --- one FEM figure end to end ----------------------------------------------------------------

@pytest.mark.fem
def test_fig14_with_fem_points_end_to_end_and_cached(tmp_path, monkeypatch):
    """Five normal-only 2L runs on an 8 x 8 grid; the second call reads them from the cache."""
    runs = tmp_path / "runs"
    make_figure("fig14", tmp_path, n=8, runs_directory=runs)
    assert (tmp_path / "fig14.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(list(runs.glob("*.h5"))) == 5
    data = read_table(tmp_path / "fig14.csv")
    finest = {load: data["area_ratio"][data["load_star"] == load][-1]
              for load in np.unique(data["load_star"])}
    loads = sorted(finest)
    assert all(finest[a] < finest[b] for a, b in zip(loads, loads[1:], strict=False))
    for load in loads:
        assert np.all(np.diff(data["area_ratio"][data["load_star"] == load]) <= 0)
    fem = [data["fem_area_ratio"][data["load_star"] == load][0] for load in loads]
    assert all(0 < area <= 1 for area in fem) and np.all(np.diff(fem) >= 0)
    # the rows: per load, the theory's area after each scale, beside that load's own FEM run
    from roughfriction.scripts import fig14
    from roughfriction.studies.post import read_run

    assert loads == sorted(fig14.LOADS)
    scales = scale_decomposition(builtin_surface("2L"))
    for load in loads:
        rows = data["load_star"] == load
        theory = normal_contact(scales, load, Material()).area_ratios
        np.testing.assert_allclose(data["area_ratio"][rows], theory, rtol=1e-9)
        np.testing.assert_array_equal(data["scale_level"][rows], np.arange(1, len(theory) + 1))
    stored = {run.load_star: run.summary["area_ratio_normal"]
              for run in map(read_run, runs.glob("*.h5"))}
    assert sorted(stored) == loads
    for load in loads:
        np.testing.assert_allclose(data["fem_area_ratio"][data["load_star"] == load],
                                   stored[load], rtol=1e-9)

    module = types.ModuleType("roughfriction.solver.run")
    module.run_loads = lambda *args, **kwargs: pytest.fail("a cached run was recomputed")
    monkeypatch.setitem(sys.modules, "roughfriction.solver.run", module)
    (tmp_path / "fig14.png").unlink()
    started = time.perf_counter()
    make_figure("fig14", tmp_path, n=8, runs_directory=runs)
    assert time.perf_counter() - started < 10.0
    assert (tmp_path / "fig14.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = read_table(tmp_path / "fig14.csv")  # drawn from the cache: the same table
    assert list(again) == list(data)
    for key in data:
        np.testing.assert_array_equal(again[key], data[key])


def test_mu_vs_psi_draws_points_not_certified_to_3_percent_hollow():
    """A FEM point whose certificate (its bar) is above 3 % of its mu_s is drawn hollow under
    its own legend entry, with the reason in the CSV; the certified ones stay filled."""
    from roughfriction.scripts import fig23
    from roughfriction.scripts.comparison import UNCERTIFIED
    from roughfriction.studies.certificate import certify

    runs = fake_runs(fig23.fem_cases(8), [0.3] * 18)
    # the 2x runs drawn: equal values, so the certificate is the resolution term alone,
    # C_b mu sqrt(N_b) / N: few contact nodes on the first two, many on the others
    for run, nodes in zip(runs[9:], [100, 400, *[40000] * 7], strict=True):
        run.summary |= {"contact_nodes": nodes, "boundary_nodes": nodes}
    fig, columns = fig23.make(runs)
    expected = [certify((0.3, 0.3), nodes, nodes).error for nodes in (100, 400, 40000)]
    assert expected[0] > expected[1] > 0.03 * 0.3 > expected[2]  # the case is as intended
    np.testing.assert_allclose(columns["mu_fem_error"][:3], expected)
    handles, labels = fig.axes[0].get_legend_handles_labels()
    label = "FEM, N = 8 (on a 2x finer mesh where barred; bar: its certified error)"
    hollow = handles[labels.index(label + UNCERTIFIED)]
    assert len(hollow.lines[0].get_xdata()) == 2 and hollow.lines[0].get_mfc() == "none"
    filled = handles[labels.index(label)]
    assert len(filled.lines[0].get_xdata()) == 7
    assert columns["fem_uncertified"][0] == (
        f"certificate {100 * expected[0] / 0.3:.1f} % of mu_s > 3 %")
    assert list(columns["fem_uncertified"][2:]) == [""] * 7
    runs = fake_runs(fig23.fem_cases(8), [0.3] * 9 + [None] * 9)  # no 2x level: no bars
    fig, columns = fig23.make(runs)
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert "FEM, N = 8" + UNCERTIFIED in labels
    assert set(columns["fem_uncertified"]) == {
        "no certificate: the 2x level did not reach sliding inception"}


def test_the_makefile_names_no_figure_and_reads_the_registry():
    """The figures are registered once (scripts/figures.py): the Makefile's figure lists come
    from it, and make expands them to the registry's names."""
    import re
    import subprocess
    from pathlib import Path

    from roughfriction.scripts.figures import FEM_FIGURES, THEORY_FIGURES

    makefile = Path(__file__).resolve().parents[1] / "Makefile"
    code = [line.split("#")[0] for line in makefile.read_text().splitlines()]
    assert not [line for line in code if re.search(r"\bfig\d+\b", line)]
    database = subprocess.run(["make", "-pn", "-f", str(makefile), "lint"], cwd=makefile.parent,
                              capture_output=True, text=True).stdout
    for name, names in (("THEORY_FIGURES", THEORY_FIGURES), ("FEM_FIGURES", FEM_FIGURES)):
        assert f"{name} := {' '.join(names)}" in database.splitlines()


def test_a_fem_figure_below_the_papers_grid_says_it_is_a_preview():
    from roughfriction.scripts import fig22
    from roughfriction.scripts.figures import label_preview

    cases = fig22.fem_cases(8)
    fig, _ = fig22.make(fake_runs(cases, [0.3] * len(cases)))
    label_preview(fig, 8)
    (note,) = [text.get_text() for text in fig.texts]
    assert note.startswith("Quick preview: FEM on 8 x 8 surface cells, not the paper's 128²")
    fig, _ = fig22.make(fake_runs(cases, [0.3] * len(cases)))
    label_preview(fig, 128)
    assert not fig.texts
