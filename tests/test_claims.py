"""scripts.claims: the paper's statements judged from figure CSVs (synthetic tables with known
answers)."""

import numpy as np
from roughfriction.scripts.claims import claims, write_claims
from roughfriction.scripts.figures import write_table

NAMES = np.array([f"G{k}" for k in range(1, 10)])
PSI = np.array([1.32, 3.34, 6.63, 10.0, 13.2, 16.59, 19.7, 23.1, 26.2])


def psi_sweep(path, mu_fem, mu_theory):
    write_table(path, {"surface": NAMES, "psi": PSI, "mu_fem": np.asarray(mu_fem, float),
                       "mu_multiscale": np.asarray(mu_theory, float)})


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
