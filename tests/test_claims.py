"""scripts.claims: the paper's statements judged from figure CSVs (synthetic tables with known
answers)."""

import numpy as np
from roughfriction.scripts.claims import claims, write_claims
from roughfriction.scripts.figures import write_table

NAMES = np.array([f"G{k}" for k in range(1, 10)])
PSI = np.array([1.32, 3.34, 6.63, 10.0, 13.2, 16.59, 19.7, 23.1, 26.2])


def psi_sweep(path, mu_fem, mu_theory, mu_error=None):
    columns = {"surface": NAMES, "psi": PSI, "mu_fem": np.asarray(mu_fem, float),
               "mu_multiscale": np.asarray(mu_theory, float)}
    if mu_error is not None:
        columns["mu_fem_error"] = np.asarray(mu_error, float)
    write_table(path, columns)


def verdicts(directory, figure: str) -> dict:
    return {paper: verdict for fig, paper, _, verdict in claims(directory) if fig == figure}


def test_psi_sweep_statements(tmp_path):
    falling = np.linspace(0.6, 0.2, 9)
    theory = falling * 0.5  # below the FEM everywhere
    psi_sweep(tmp_path / "fig22.csv", falling, theory)
    found = verdicts(tmp_path, "22")
    assert found["μ_s decreases as ψ increases (FEM)"] == "yes"
    assert found["multi-scale below the FEM"] == "yes"
    assert found["μ_s(ψ = 16.59) > μ_s(ψ = 13.20) (FEM)"] == "no"  # monotone: G6 < G5
    psi_sweep(tmp_path / "fig22.csv", falling[::-1], theory * 4)
    found = verdicts(tmp_path, "22")
    assert found["μ_s decreases as ψ increases (FEM)"] == "no"
    assert found["multi-scale below the FEM"] == "no"
    assert found["μ_s(ψ = 16.59) > μ_s(ψ = 13.20) (FEM)"] == "yes"


def test_the_model_below_the_fem_is_judged_beyond_the_bars(tmp_path):
    theory = np.linspace(0.6, 0.2, 9)
    psi_sweep(tmp_path / "fig22.csv", theory * 1.02, theory, theory * 0.03)  # 2 % above, 3 % bars
    found = verdicts(tmp_path, "22")
    assert found["multi-scale below the FEM"] == "within the bars"
    psi_sweep(tmp_path / "fig22.csv", theory * 1.05, theory, theory * 0.03)
    assert verdicts(tmp_path, "22")["multi-scale below the FEM"] == "yes"
    below = theory * np.where(np.arange(9) < 2, 0.9, 1.05)  # two points 10 % below, 3 % bars
    psi_sweep(tmp_path / "fig22.csv", below, theory, theory * 0.03)
    row = next(row for row in claims(tmp_path) if row[1] == "multi-scale below the FEM")
    assert row[3] == "no" and "FEM below at 2" in row[2] and "0.9±0.03" in row[2]


def test_missing_figures_give_no_verdict_and_high_load_closeness(tmp_path):
    assert verdicts(tmp_path, "23") == {"(figure not drawn)": "—"}
    fem = np.linspace(0.6, 0.2, 9)
    psi_sweep(tmp_path / "fig22.csv", fem, fem / 3)  # 3x apart at low load
    psi_sweep(tmp_path / "fig25.csv", fem, fem / 1.1)  # 10 % apart at high load
    assert verdicts(tmp_path, "22–25")["FEM and multi-scale closer at high load"] == "yes"


def test_junction_growth_and_complete_contact(tmp_path):
    write_table(tmp_path / "fig15.csv", {"ux_m": np.array([0.0, 1e-7]),
                                         "area_ratio": np.array([0.16, 0.19])})
    rows = [row for row in claims(tmp_path) if row[0] == "15"]
    assert rows[0][2].startswith("+18.8 %") and rows[0][3] == "yes"
    surfaces = np.repeat(NAMES[:2], 2)
    write_table(tmp_path / "fig20.csv", {
        "surface": surfaces, "psi": np.repeat(PSI[:2], 2),
        "load_star": np.tile([0.155, 1.86], 2), "area_ratio": np.array([0.3, 0.995, 0.2, 0.8])})
    found = verdicts(tmp_path, "20")
    assert found["G1 in complete contact at F* = 1.86"] == "yes"
    assert found["F* = 0.155: A_r/A_n lower for larger ψ in most cases"] == "yes"


def test_load_sweep_statements(tmp_path):
    loads = np.array([0.06, 0.5, 1.86])
    theory_loads = np.array([0.05, 0.5, 2.0])
    write_table(tmp_path / "fig26.csv", {
        "model": np.array(["fem"] * 3 + ["multiscale"] * 3),
        "load_star": np.concatenate([loads, theory_loads]),
        "mu_s": np.array([0.6, 0.4, 0.3, 0.28, 0.29, 0.3])})
    found = verdicts(tmp_path, "26")
    assert found["2L: multi-scale μ_s nearly constant in F*"] == "yes"
    assert found["2L: FEM μ_s decreases with load"] == "yes"
    assert found["2L: FEM approaches the model at high load"] == "yes"
    path = write_claims(tmp_path)
    assert path.read_text().startswith("| Fig. | the paper | ours | agrees |")
    # every row has its four cells ("ours" holds no "|": a markdown table would split it)
    rows = [line.strip().strip("|").split("|") for line in path.read_text().splitlines()[2:]]
    assert {len(cells) for cells in rows} == {4}
    written = [(cells[0].strip(), cells[1].strip(), cells[-1].strip()) for cells in rows]
    assert {paper: verdict for fig, paper, verdict in written if fig == "26"} == found
    assert len(written) == len(claims(tmp_path))  # one row per statement, figures not drawn too


def test_low_load_and_approach_with_bars(tmp_path):
    loads = np.array([0.06, 0.155, 1.86])
    theory_loads = np.array([0.05, 0.5, 2.0])
    mu_theory = np.full(3, 0.3)

    def sweep(mu_fem, bars):
        write_table(tmp_path / "fig28.csv", {
            "model": np.array(["fem"] * 3 + ["multiscale"] * 3),
            "load_star": np.concatenate([loads, theory_loads]),
            "mu_s": np.concatenate([mu_fem, mu_theory]),
            "mu_fem_error": np.concatenate([bars, np.full(3, np.nan)])})
        return verdicts(tmp_path, "28")

    found = sweep(np.array([0.33, 0.33, 0.303]), np.full(3, 0.006))  # 10 % above at low load
    assert found["G5: FEM above the model at low load"] == "yes"
    assert found["G5: FEM approaches the model at high load"] == "yes"
    found = sweep(np.array([0.306, 0.303, 0.303]), np.full(3, 0.006))  # 1-2 % above, 2 % bars
    assert found["G5: FEM above the model at low load"] == "within the bars"
    assert found["G5: FEM approaches the model at high load"] == "within the bars"
    found = sweep(np.array([0.27, 0.30, 0.36]), np.full(3, 0.006))
    assert found["G5: FEM above the model at low load"] == "no"
    assert found["G5: FEM approaches the model at high load"] == "no"


def test_stiffness_orderings(tmp_path):
    """Fig. 21 asks the normalised first-step slope to rise with psi, Fig. 29 the raw one to
    fall."""
    rising = {"surface": np.repeat(NAMES[:3], 2), "psi": np.repeat(PSI[:3], 2),
              "ux_over_omega0": np.tile([0.0, 1.0], 3), "ux_m": np.tile([0.0, 1.0], 3),
              "Ft_over_Fn": np.array([0.0, 0.1, 0.0, 0.2, 0.0, 0.3])}
    write_table(tmp_path / "fig21.csv", rising)
    write_table(tmp_path / "fig29.csv", rising)
    assert list(verdicts(tmp_path, "21").values()) == ["yes"]
    assert list(verdicts(tmp_path, "29").values()) == ["no"]
