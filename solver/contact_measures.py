"""Measures of a contact state over all ranks (collective calls): the deepest penetration,
integrals of point densities (F_n, F_t, the stuck points' shear reserve, the contact area),
node counts, the N x N nodal maps, and a first guess of the flat height that carries a force
(:class:`solver.contact.RigidFlat` has them as methods)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from mpi4py import MPI

if TYPE_CHECKING:
    from roughfriction.solver.contact_state import ContactResponse


class ContactMeasures:
    """Forces, areas, counts and maps of contact states on the surface :attr:`surface`
    (:class:`solver.contact_quadrature.SurfaceQuadrature`) under the contact law :attr:`law`
    (:class:`solver.contact_law.ContactLaw`), set by the subclass."""

    def penetration(self, response: ContactResponse) -> float:
        """Deepest penetration -g~_a of a node in contact [m], over all ranks."""
        owned = self.surface.owned_grid
        deepest = np.max(-response.node_gap[owned][response.node_active[owned]], initial=0.0)
        return float(self.surface.comm.allreduce(deepest, op=MPI.MAX))

    def integrate(self, point_values: np.ndarray) -> float:
        """sum_q A_f w_q v_q over all faces of all ranks: the integral of a point density
        [x m^2]."""
        return float(self.surface.comm.allreduce(float(self.surface.counted_area @ point_values)))

    def normal_force(self, response: ContactResponse) -> float:
        """F_n = integral of p over the surface [N]."""
        return self.integrate(response.pressure)

    def tangential_force(self, response: ContactResponse) -> float:
        """F_t = integral of t_x: the x force needed to hold the flat [N]."""
        return self.integrate(response.traction[:, 0])

    def stuck_shear_reserve(self, response: ContactResponse) -> float:
        """The x force the sticking contact points could still add before they slip: the
        integral of c(p) - t_x over the points in contact below the cap [N] (a collective
        call)."""
        sticking = response.in_contact & ~response.slipping
        reserve = self.law.shear_cap(response.pressure) - response.traction[:, 0]
        return self.integrate(np.where(sticking, reserve, 0.0))

    def area_ratio(self, mask: np.ndarray) -> float:
        """Fraction of the nominal area whose points satisfy ``mask`` (e.g. p > 0) [-]."""
        return self.integrate(mask) / (self.surface.grid_size * self.surface.spacing) ** 2

    def count(self, mask: np.ndarray) -> int:
        """Number of surface nodes (over all ranks) where the node ``mask`` holds [-]."""
        return int(self.surface.comm.allreduce(np.count_nonzero(mask[self.surface.owned_grid])))

    def node_maps(self, response: ContactResponse) -> dict:
        """N x N nodal maps ([i, j] at x = i h, y = j h on the finest grid) of a contact state,
        the same on every rank (a collective call).

        "contact": p_a > 0 (bool); "slip": in contact and every point of its tributary area
        slipping (bool); "pressure" and "shear_x": the consistent nodal forces over the node's
        tributary area A_a [Pa]; "contact_fraction": per finest cell (i, j), the fraction of the
        area of the face holding it in contact [-]; "gap": the weighted gap g~_a between the
        flat and the deformed surface [m] (negative: penetration). Grid points without a free
        surface node (inside a coarse face, or where it hangs) are out of contact with zero
        forces and no gap (NaN).
        """
        surface = self.surface
        n, owned = surface.grid_size, surface.owned_grid
        touching_area = surface.tributary @ response.in_contact.astype(float)
        sticking_area = surface.tributary @ (response.in_contact & ~response.slipping).astype(float)
        area = surface.node_area[owned]
        nodal = surface.gather_nodes(np.column_stack([
            touching_area[owned], sticking_area[owned], response.node_force[owned, 2] / area,
            -response.node_force[owned, 0] / area, response.node_gap[owned]]))
        fraction = (surface.point_weight * response.in_contact).reshape(len(surface.face_area),
                                                                       -1).sum(axis=1)
        face_fraction = np.zeros(surface.num_faces)
        face_fraction[surface.face_ids[surface.face_counted]] = fraction[surface.face_counted]
        touching, sticking = nodal[:, 0] > 0.0, nodal[:, 1] > 0.0
        return {
            "contact": touching.reshape(n, n),
            "slip": (touching & ~sticking).reshape(n, n),
            "pressure": nodal[:, 2].reshape(n, n),
            "shear_x": nodal[:, 3].reshape(n, n),
            "contact_fraction": surface.faces.on_grid(surface.comm.allreduce(face_fraction)),
            "gap": np.where(surface.surface_node, nodal[:, 4], np.nan).reshape(n, n),
        }

    def touching_height(self, displacement: np.ndarray, force: float,
                        elastic_modulus: float) -> float:
        """A first guess of the flat height h [m] carrying ``force`` [N] from ``displacement``,
        over all ranks' nodes (a collective call).

        Every node is a spring k, the penalty eps a in series with the solid under it, taken as
        a uniformly loaded square of its tributary area a = A_a on a half-space (mean
        deflection 0.95 p sqrt(a) / E', Timoshenko & Goodier), and sum k <-g~_a(h)> = force is
        solved exactly (the penalty alone would put the whole load on the highest
        point, from where Newton overshoots into deep penetration).

        Parameters
        ----------
        displacement : numpy.ndarray
            Local displacement array [m], shape (num_nodes, 3).
        force : float
            Normal force [N].
        elastic_modulus : float
            E' = E / (1 - nu^2) [Pa].
        """
        surface = self.surface
        owned = surface.owned_grid
        tops = (surface.tributary @ (surface.heights + surface.interpolate(
            surface.gather_nodes(displacement[surface.nodes, 2]))))[owned]  # h - g~_a [m]
        tops, area = surface.gather_nodes(np.column_stack([tops, surface.node_area[owned]]))[
            surface.surface_node].T
        stiffness = 1.0 / (1.0 / (self.law.penalty * area)
                           + 0.95 / (elastic_modulus * np.sqrt(area)))
        order = np.argsort(tops)[::-1]
        tops, stiffness = tops[order], stiffness[order]
        # with the m highest nodes in contact: h = (sum k z - force) / sum k
        heights = (np.cumsum(stiffness * tops) - force) / np.cumsum(stiffness)
        below_next = np.append(heights[:-1] >= tops[1:], True)
        return float(heights[np.argmax(below_next)])
