"""One run's pictures (``roughfriction post RUN --plot DIR``), on the synthetic run of
tests/test_post.py: what each figure shows, with its units, and the files the command writes."""

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.scripts.cli import EXIT_INPUT_ERROR, main
from roughfriction.scripts.fem_views import (
    contact_maps,
    run_contact_figure,
    run_tangential_figure,
    write_run_plots,
)
from roughfriction.scripts.figures import save_png
from roughfriction.studies.post import read_run, tangential_curve

from tests.test_post import STEPS, contact_map, normal_maps, write_run


def sliding_maps():
    """The preload's maps and, at inception, one more contact node at higher pressure."""
    contact = contact_map()
    contact[5, 5] = True
    return {**normal_maps(), "contact_sliding": contact,
            "pressure_sliding": np.where(contact, 3e9, 0.0),
            "contact_fraction_sliding": np.where(contact, 0.5, 0.0),
            "slip_sliding": contact, "shear_x_sliding": np.where(contact, 1e8, 0.0)}


@pytest.fixture(scope="module")
def sliding_run(tmp_path_factory):
    return read_run(write_run(tmp_path_factory.mktemp("views") / "slid.h5", maps=sliding_maps()))


def colorbar_labels(fig):
    return {ax.get_ylabel() for ax in fig.axes if getattr(ax, "_colorbar", None) is not None}


def test_contact_figure_shows_preload_and_inception_pressures(sliding_run):
    fig = run_contact_figure(sliding_run)
    panels = [ax for ax in fig.axes if getattr(ax, "_colorbar", None) is None]
    assert len(panels) == 2
    assert panels[0].get_title().startswith("End of preload")
    assert panels[1].get_title().startswith("Sliding inception")
    assert "7 contact nodes" in panels[1].get_title()
    for ax in panels:
        assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (µm)", "y (µm)")
    assert colorbar_labels(fig) == {"contact pressure $p$ (MPa)", "surface height $z$ (µm)"}
    pressure = panels[1].get_images()[1].get_array()  # the overlay, [MPa], masked off contact
    assert pressure.max() == pytest.approx(3e3) and pressure.count() == 7


def test_tangential_figure_is_the_curve_with_mu_s(sliding_run):
    fig = run_tangential_figure(sliding_run)
    (ax,) = fig.axes
    curve = tangential_curve(sliding_run)
    x, y = ax.get_lines()[0].get_data()
    np.testing.assert_allclose(x, curve["ux_m"] / 1e-9)
    np.testing.assert_allclose(y, curve["Ft_over_Fn"])
    assert ax.get_lines()[1].get_ydata()[0] == pytest.approx(0.6)  # mu_s
    assert ax.get_xlabel() == "slide of the flat $u_x$ (nm)"
    assert ax.get_ylabel() == "$F_t / F_n$ (–)"


def test_post_plot_writes_both_pngs(sliding_run, tmp_path, capsys):
    assert main(["post", str(sliding_run.path), "--plot", str(tmp_path / "plots")]) == 0
    written = sorted((tmp_path / "plots").iterdir())
    assert [path.name for path in written] == ["slid_contact.png", "slid_tangential.png"]
    for path in written:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"plots_written       {tmp_path / 'plots' / 'slid_contact.png'}" in \
        capsys.readouterr().out


def test_a_preload_only_run_draws_its_contact_map_alone(tmp_path):
    run = read_run(write_run(tmp_path / "normal.h5", STEPS[:2]))
    written = write_run_plots(run, tmp_path / "plots")
    assert [path.name for path in written] == ["normal_contact.png"]


def test_a_run_without_contact_or_slide_is_refused(tmp_path, capsys):
    path = write_run(tmp_path / "empty.h5", STEPS[:1], converged=False, message="failed",
                     maps={})
    with pytest.raises(InputError, match="nothing to draw"):
        write_run_plots(read_run(path), tmp_path / "plots")
    assert main(["post", str(path), "--plot", str(tmp_path / "plots")]) == EXIT_INPUT_ERROR
    assert "nothing to draw" in capsys.readouterr().err


# --- contact maps at any N: every contact cell on screen --------------------------------------

#: A PNG pixel is coloured (a contact cell, not the grey heights or black text) when its RGB
#: channels differ by more than this [-].
COLOURED = 0.25


def isolated_cells(n: int, rng) -> np.ndarray:
    """An n x n contact map of single contact cells, none touching another (8-neighbours)."""
    contact = np.zeros((n, n), bool)
    lattice = np.arange(0, n, 3)
    picked = rng.choice(lattice.size**2, size=min(60, lattice.size**2), replace=False)
    contact[lattice[picked // lattice.size], lattice[picked % lattice.size]] = True
    return contact


def isolated_contact_run(tmp_path, n: int):
    """A run whose n x n maps hold isolated contact cells at the preload and at inception."""
    rng = np.random.default_rng(n)
    contact = {phase: isolated_cells(n, rng) for phase in ("normal", "sliding")}
    maps = {"surface_heights": rng.normal(0.0, 0.1e-6, (n, n))}
    for phase, cells in contact.items():
        maps[f"contact_{phase}"] = cells
        maps[f"pressure_{phase}"] = np.where(cells, rng.uniform(1e8, 3e9, (n, n)), 0.0)
    return read_run(write_run(tmp_path / f"isolated_{n}.h5", maps=maps))


def coloured_blob_sizes(png, fig, ax) -> np.ndarray:
    """Pixels of each connected coloured blob inside ``ax`` of ``fig`` saved as ``png``."""
    from matplotlib.image import imread
    from scipy import ndimage

    image = imread(png)[..., :3]
    scale = image.shape[1] / fig.bbox.width  # PNG pixels per figure pixel
    box = ax.get_window_extent()
    rows = slice(image.shape[0] - round(box.y1 * scale), image.shape[0] - round(box.y0 * scale))
    columns = slice(round(box.x0 * scale), round(box.x1 * scale))
    panel = image[rows, columns]
    labels, _ = ndimage.label(panel.max(axis=2) - panel.min(axis=2) > COLOURED)
    return np.bincount(labels.ravel())[1:]


def map_panels(fig):
    return [ax for ax in fig.axes if getattr(ax, "_colorbar", None) is None]


@pytest.mark.parametrize("n", [128, 512])
@pytest.mark.parametrize("drawing", ["post --plot", "fig8"])
def test_every_isolated_contact_cell_is_on_screen(tmp_path, n, drawing):
    """Each isolated contact cell is its own coloured square of the PNG, all of the same whole
    number of pixels: no cell is blurred away, at any N."""
    run = isolated_contact_run(tmp_path, n)
    fig = run_contact_figure(run) if drawing == "post --plot" else contact_maps([run])[0]
    png = save_png(fig, tmp_path / "contact.png")
    phases = ("normal", "sliding") if drawing == "post --plot" else ("normal",)
    for ax, phase in zip(map_panels(fig), phases, strict=True):
        sizes = coloured_blob_sizes(png, fig, ax)
        assert sizes.size == np.count_nonzero(run.maps[f"contact_{phase}"])
        side = np.sqrt(sizes)
        assert np.all(side == side[0]) and side[0] == round(side[0]) >= 1


#: Least width of a PNG for README width on a high-density screen [px] (the old PNGs: 550).
MIN_PNG_WIDTH = 1000


def test_post_pngs_are_sharp(sliding_run, tmp_path):
    from matplotlib.image import imread

    for path in write_run_plots(sliding_run, tmp_path):
        assert imread(path).shape[1] >= MIN_PNG_WIDTH
