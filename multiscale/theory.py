"""Every theory prediction for one surface and one load, side by side (the CLI's ``multiscale``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from roughfriction.case import check_load_star, check_surface_slope
from roughfriction.geometry.statistics import surface_statistics
from roughfriction.geometry.surface import Surface
from roughfriction.material import Material
from roughfriction.multiscale.friction import static_friction
from roughfriction.multiscale.scales import Scales, scale_decomposition
from roughfriction.multiscale.statistical import cke_friction, let_friction


@dataclass(frozen=True)
class TheoryResult:
    """Multi-scale model (Sect. 4.2) beside the statistical CKE (Eq. 8) and LET (Eq. 20) models.

    Attributes
    ----------
    surface : str
        Surface name.
    load_star : float
        F* = F_n / (A_n S_y) [-].
    psi : float
        Plasticity index (Eq. 11) [-].
    mu_s : float
        Multi-scale static friction coefficient (F_t)max / F_n [-].
    Ft_max : float
        Maximum tangential load of the multi-scale model [N] over A_n = L^2.
    area_ratio_normal, area_ratio_sliding : float
        A_r / A_n under normal load only and at sliding inception [-].
    mu_cke, mu_let : float
        CKE and LET static friction coefficients [-], computed even outside their ranges.
    cke_valid, let_valid : bool
        Whether (psi, F*) lies inside the published range of each statistical model.
    converged : bool
        Whether the multi-scale load iteration converged.
    """

    surface: str
    load_star: float
    psi: float
    mu_s: float
    Ft_max: float
    area_ratio_normal: float
    area_ratio_sliding: float
    mu_cke: float
    mu_let: float
    cke_valid: bool
    let_valid: bool
    converged: bool

    def as_dict(self) -> dict:
        return asdict(self)


def evaluate_theory(
    surface: Surface,
    load_star: float,
    material: Material,
    *,
    variant: str = "A",
    scales: Scales | None = None,
    psi: float | None = None,
) -> TheoryResult:
    """Multi-scale, CKE and LET static friction of ``surface`` at the load F* [-].

    ``scales`` and ``psi`` may be passed in when the same surface is evaluated at many loads
    (they depend on the surface only). A load or surface the FEM would refuse is refused here
    too (``roughfriction.case.check_load_star`` and ``check_surface_slope``).
    """
    check_load_star(load_star)
    check_surface_slope(surface)
    scales = scale_decomposition(surface) if scales is None else scales
    psi = surface_statistics(surface, material).psi if psi is None else psi
    friction = static_friction(scales, load_star, material, variant=variant)
    cke = cke_friction(psi, load_star)
    let = let_friction(psi, load_star)
    return TheoryResult(
        surface=surface.name,
        load_star=float(load_star),
        psi=float(psi),
        mu_s=float(friction.mu_s),
        Ft_max=float(friction.Ft_max),
        area_ratio_normal=float(friction.area_ratio_normal),
        area_ratio_sliding=float(friction.area_ratio_sliding),
        mu_cke=float(cke.mu_s),
        mu_let=float(let.mu_s),
        cke_valid=bool(cke.valid),
        let_valid=bool(let.valid),
        converged=bool(friction.converged),
    )
