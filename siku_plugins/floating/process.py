"""``floating``: elements that float, with heave, roll and pitch in still water and in waves.

Linear seakeeping of each element as a rigid prism of its polygon (area ``A`` [m²], thickness
``h`` [m], density ``rho_i``) floating in water of density ``rho_w``: draft ``d = h rho_i /
rho_w``, mass ``m = rho_i h A``. The vertical degrees of freedom are decoupled, in linear
theory, from the horizontal motion the engine integrates, so this process owns them as declared
per-element fields and advances them itself after each step (sub-stepping, below):

* ``heave`` ζ [m], the rise of the element's centre of mass above its floating position in
  still water, and ``heave_rate`` [m/s]:

      (m + A33) ζ'' = rho_w g A [clamp(d - ζ + ∫ eta_d dA / A, 0, h) - d] - B33 ζ'

  (linear: ``-rho_w g A ζ + rho_w g ∫ eta_d dA``, the hydrostatic restoring and the wave's
  load, as long as the element is neither out of the water nor under it; beyond, buoyancy and
  wave load saturate: released from any height it falls and settles at draft ``d``, and a
  floe overtopped by a wave feels at most its whole volume's buoyancy);
* the tilts ``roll`` and ``pitch`` [rad] about the element's local x and y axes (right-handed,
  z up: positive roll raises the +y side, positive pitch lowers the +x side), and their rates
  [rad/s]. They are integrated as the slopes ``s_k`` of the element along the principal axes
  ``k = 1, 2`` of its waterplane (second moments ``J_k``, ``siku_plugins.floating.geometry``):

      (rho_i h J_k + m h²/12 + A_k) s_k'' = -C_k s_k - B_k s_k' + rho_w g ∫ u_k eta_d dA,
      C_k = rho_w g [J_k - A d (h - d) / 2]

  (``C_k`` the hydrostatic restoring with the centre of buoyancy ``d/2`` below the water line
  and the centre of gravity ``h/2 - d`` above it; an element with ``C_k <= 0`` capsizes alone
  and is refused).

``eta_d`` is the Froude–Krylov pressure head of the incident wave at the draft, from the wave
field of the scene's first ``[[forcing]]`` table that has one (``linear_wave``, ``jonswap``;
``wave = "none"``: still water): ``eta_d = sum a_j att_j cos(psi_j)``, ``att_j = e^{-k_j d}``
in deep water, ``cosh(k_j (H - d)) / cosh(k_j H)`` in water of depth ``H``, integrated over the
element's bottom by quadrature (``siku_plugins.floating.geometry``; by default as fine as the
shortest wave needs) at its present horizontal position; in a ``spectral`` field (a sea the
ice damps) ``a_j = sqrt(2 E_j)`` of the cell of the element's centre (:meth:`Floating._local`).
``wave = "exchange"``: a coupled model's elevation and dynamic pressure through the BMI
(``siku_plugins.floating.coupled``). The wave's load is Froude–Krylov only.

Added mass and damping: ``coefficients = "auto"`` (the default) takes the scene's (below) when
the scene sets any of their four parameters or has no wave field, else capytaine's at the
frequency of the wave field's largest component where capytaine is installed and the free
elements have at most :data:`AUTO_CAPYTAINE_SHAPES` shapes, else the long-wave approximation
of a floe small against the wavelength at that frequency (``coefficients = "small_body"``,
``siku_plugins.floating.small_body``; an element not small against it keeps the scene's).
With ``coefficients = "scene"``, ``A33 = added_mass rho_w A^{3/2}``,
``A_k = added_inertia rho_w A^{1/2} J_k``, ``B33 = 2 damping_ratio sqrt((m + A33) rho_w g A)``,
``B_k = 2 tilt_damping_ratio sqrt(M_k C_k)``; defaults: capytaine's for a 10 × 10 × 1 m block.
With ``coefficients = "capytaine"`` (the optional extra ``siku[hydro]``) they are capytaine's
A(omega), B(omega) of each element's prism at the natural frequency of each mode, computed once
per shape and cached on disk (``siku_plugins.floating.hydro``). With ``radiation = "memory"``
the radiation force of each mode is Cummins' convolution of its rate with the impulse response
of capytaine's B(omega) on a band, and its added mass A(infinity) (``.memory``); otherwise (the
default) the coefficients are constant: a transient's radiation memory is not modelled.

Time stepping: velocity Verlet, damping half explicit, half implicit (``kernels.advance``), in
sub-steps of at most ``T_min / steps_per_period``, ``T_min`` the shortest natural period of
any free element's modes: no limit on the scene's ``dt`` (the period error is ``(2 pi /
steps_per_period)² / 24``, 0.04 % by default); the wave load at every sub-step at the element's
horizontal position at the end of the engine's step.

``wave_radiated_power`` [W m-2]: the radiation damping's power per unit area over the step
(trapezoid over the sub-steps of ``B33 ζ'² + B_1 s_1'² + B_2 s_2'²``, or of the memory force
times the rates); its total [W] is the diagnostic of the same name. Only free elements float.
"""
from __future__ import annotations

import copy
import math
from typing import ClassVar

import numpy as np

from siku_core.categories import SUM_TOLERANCE
from siku_core.errors import SceneError
from siku_core.fields import ElementField
from siku_core.run.limits import check_work
from siku_core.parallel import ITEM_NS, PARALLEL_MIN, chunks
from siku_core.interfaces import Process
from siku_core.params import Param
from siku_core.state import FREE

from .geometry import lattice_arrays, principal, quadrature, second_moments
from .bending import advance_jointed, equilibrium, joint_stresses, shortest_period
from .kernels import FloatingBodies, FloatingPoints, FloatingWave, advance, motion

#: the most distinct shapes of free elements for which ``coefficients = "auto"`` solves with
#: capytaine (three solves a shape, seconds each, cached); more take ``small_body``
AUTO_CAPYTAINE_SHAPES = 16
#: one element's load and sub-step [ns, one thread]: its chunks (``siku_core.parallel.chunks``)
FLOAT_NS = 150.0
_NO_EXT, _NO_KAP = np.zeros((0, 3)), np.zeros((0, 0, 3, 2))

FIELDS = (
    ElementField("heave", "m", "rise of the element's centre of mass above its floating "
                 "position in still water"),
    ElementField("heave_rate", "m s-1", "vertical velocity of the element"),
    ElementField("roll", "rad", "tilt about the element's local x axis (+y side up)"),
    ElementField("roll_rate", "rad s-1", "rate of roll"),
    ElementField("pitch", "rad", "tilt about the element's local y axis (+x side down)"),
    ElementField("pitch_rate", "rad s-1", "rate of pitch"),
    ElementField("wave_radiated_power", "W m-2", "rate at which the element's radiation "
                 "damping takes energy from its heave, roll and pitch, per unit area, averaged "
                 "over the last step (B33 z'^2 + B_1 s_1'^2 + B_2 s_2'^2, or the memory "
                 "force's work, over the area)"),
)


class Floating(Process):
    """Heave, roll and pitch of floating elements: buoyancy, added mass, radiation damping and
    the Froude–Krylov load of the scene's waves (linear, per element)."""

    name = "floating"
    #: on MPI ranks each rank's copy takes the run's set-up for its elements
    #: (:meth:`setup_on_rank`); with ``bending = true`` it reads the joints (set up), and its
    #: ghosts take their owners' heave and tilts each sub-step
    runs_on_ranks = True
    #: ``radiation = "memory"``: the ring buffers, one per element, and their shared head
    rank_history: ClassVar[dict[str, str]] = {"rates": "element", "head": "same"}
    owned_fields = FIELDS
    integrates: ClassVar[dict[str, str]] = {  # its degrees of freedom, for the engine's guard
        **dict.fromkeys(("heave", "roll", "roll_rate", "pitch", "pitch_rate"), "finite"),
        "heave_rate": "speed"}
    diagnostic_units: ClassVar[dict[str, str]] = {"wave_radiated_power": "W"}
    params: ClassVar[dict[str, Param]] = {
        "rho_water": Param(1026.0, "kg/m^3", "water density rho_w", min=1e-6),
        "g": Param(9.81, "m/s^2", "gravitational acceleration", min=0.01, max=100.0),
        "coefficients": Param("auto", "", "added mass and damping: from these parameters "
                              "('scene'), from capytaine, cached ('capytaine'), from the "
                              "long-wave limit at the wave's frequency ('small_body'), or "
                              "'auto': 'scene' when the scene sets added_mass, "
                              "damping_ratio, added_inertia or tilt_damping_ratio to other "
                              "than its default or has no wave field, else "
                              "capytaine's at the wave's frequency where it is installed "
                              "and the free elements have at most 16 shapes, else "
                              "'small_body'", type=str,
                              choices=("auto", "scene", "capytaine", "small_body")),
        "added_mass": Param(0.244, "1", "heave added mass A33 / (rho_w A^1.5)", min=0.0),
        "damping_ratio": Param(0.172, "1", "heave radiation damping as a fraction of "
                               "critical, B33 / (2 sqrt((m + A33) rho_w g A))", min=0.0),
        "added_inertia": Param(0.139, "1", "tilt added inertia A_k / (rho_w A^0.5 J_k)",
                               min=0.0),
        "tilt_damping_ratio": Param(0.100, "1", "tilt radiation damping as a fraction of "
                                    "critical", min=0.0),
        "wave": Param("auto", "", "the incident wave: 'auto' (the field of the first "
                      "[[forcing]] table with a wave field; still water if none), 'none', or "
                      "'exchange' (a coupled model's elevation and pressure through the BMI "
                      "and the exchange grid)", type=str, choices=("auto", "none", "exchange")),
        "ramp": Param(0.0, "s", "the wave's loads grow from 0 as (1 - cos(pi t / ramp)) / 2 "
                      "over the first ramp seconds (0: from the start)", min=0.0),
        "initial_heave": Param(0.0, "m", "heave of every free element at the start"),
        "initial_roll": Param(0.0, "rad", "roll of every free element at the start"),
        "initial_pitch": Param(0.0, "rad", "pitch of every free element at the start"),
        "steps_per_period": Param(64, "1", "sub-steps per shortest natural period (4096: a "
                                  "period error of 1e-7)", type=int, min=8, max=4096),
        "quadrature": Param(0, "1", "subdivisions of each edge triangle for the wave load "
                            "(0: ceil(k_max R / 0.7), R the element's bounding radius: errors "
                            "below 1e-4 in heave, 1e-3 in the tilts)", type=int, min=0,
                            max=64),
        "frequency": Param("natural", "", "capytaine's coefficients at each mode's natural "
                           "frequency ('natural') or at the frequency of the wave field's "
                           "largest component ('wave': exact for a monochromatic sea)",
                           type=str, choices=("natural", "wave")),
        "diffraction": Param(False, "", "add the diffraction load to the Froude–Krylov one: "
                             "capytaine's excitation of each element's prism for each wave "
                             "component, at the element's heading at the start", type=bool),
        "bending": Param(False, "", "the intact joints are beams that carry vertical shear "
                         "and bending moments between their elements, and break in flexure "
                         "(siku_plugins.floating.bending; needs a [contact] table)", type=bool),
        "flexural_strength": Param(1e6, "Pa", "bending stress 6 M / (w h²) that breaks a "
                                   "joint (with bending = true)", min=0.0),
        "loads": Param([], "N", "constant vertical forces [[element, F_z], ...] on elements, "
                       "upward positive (a load on the ice)", type=list),
        "radiation": Param("constant", "", "radiation force from constant added mass and "
                           "damping ('constant') or from the impulse response of "
                           "capytaine's B(omega) of each mode on a band ('memory': "
                           "Cummins' equation, siku_plugins.floating.memory)", type=str,
                           choices=("constant", "memory")),
        "memory_omega_max": Param(0.0, "rad/s", "top of the band of radiation = 'memory' (0: "
                                  "sqrt(2 pi g / (6 mesh size)), six panels a wavelength)",
                                  min=0.0),
        "memory_bins": Param(40, "1", "frequencies of the band (uniform from its top / bins)",
                             type=int, min=4, max=400),
        "memory_tol": Param(1e-2, "1", "truncation of the kernel: its neglected tail, as "
                            "an error of B(omega), at most memory_tol max B", min=1e-6,
                            max=0.5),
        "hydro_cache": Param("", "", "folder of capytaine's cached coefficients ('': the user "
                             "cache, siku/hydro)", type=str),
        "mesh_size": Param(0.0, "m", "largest panel of capytaine's mesh (0: a sixteenth of "
                           "the element's smallest width)", min=0.0),
    }

    #: the coefficients set up: "scene", "capytaine" or "small_body"
    coefficients_used = ""
    #: on an MPI rank, the rank's place in the run (``siku_core.ranks.local.RankLink``)
    link = None

    # ------------------------------------------------------------------ set-up
    def setup(self, ctx) -> None:
        st = ctx.state
        p = self.p
        where = f"{ctx.where(self.table)}: process 'floating'"
        n = st.n
        mats = list(ctx.scene.cfg.materials.items())
        rho_w, g = float(p["rho_water"]), float(p["g"])
        free = st.flags == FREE
        rho_i = np.array([mats[k][1].density for k in st.material], dtype=float)
        for k in np.unique(st.material[free]) if n else ():
            name, mat = mats[k]
            if not mat.density < rho_w:
                raise SceneError(f"{where}: material '{name}' has density {mat.density:g} "
                                 f"kg/m3, not below the water's {rho_w:g} kg/m3: it cannot "
                                 "float")
        cats = ctx.categories
        if cats is not None:  # a floe's mass rho_i h A: its ice must cover it whole
            c = cats.fraction.sum(axis=1)
            bad = free & (c < 1.0 - SUM_TOLERANCE)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise SceneError(f"{where}: element {i} has ice on {c[i]:.6g} of its area "
                                 "(thickness categories); a floating element is a floe that "
                                 "its ice covers whole")
        h = st.thickness.astype(float)
        draft = h * rho_i / rho_w
        if np.any(free & ~(draft > 0)):
            i = int(np.flatnonzero(free & ~(draft > 0))[0])
            raise SceneError(f"{where}: element {i} has draft {draft[i]:g} m; a floating "
                             "element needs a positive thickness and density")
        # waterplane: principal axes and second moments, quadrature points
        area = st.area.astype(float)
        phi = np.zeros(n)
        J1 = np.zeros(n)
        J2 = np.zeros(n)
        qa, qb, qw, off, lat = [], [], [], [0], []
        # the wave field first: the quadrature follows its shortest wave
        self._wave(ctx)
        kmax = float(np.max(self.field.k)) if self.field is not None and len(
            self.field.k) else 0.0
        for i in range(n):
            poly = st.polygon(i)
            _, ixx, iyy, ixy = second_moments(poly)
            phi[i], J1[i], J2[i] = principal(ixx, iyy, ixy)
            if free[i]:
                nq = int(p["quadrature"]) or min(64, max(1, math.ceil(
                    kmax * float(st.radius[i]) / 0.7 - 1e-9)))
                pts, w = quadrature(poly, nq)
                qa.append(pts[:, 0])
                qb.append(pts[:, 1])
                qw.append(w)
                off.append(off[-1] + len(w))
            else:
                off.append(off[-1])
            lat.append((poly, nq) if free[i] else None)
        voff, vx, vy, m6, ia, ib, zsize = lattice_arrays(lat)   # the points on the vertices
        qa, qb, qw = (np.concatenate(x) if x else np.zeros(0) for x in (qa, qb, qw))
        qoff = np.array(off, dtype=np.int64)
        c, s = np.cos(phi), np.sin(phi)
        elem = np.repeat(np.arange(n), np.diff(qoff))
        self.points = FloatingPoints(
            qoff=qoff, qa=qa, qb=qb, qu=qa * c[elem] + qb * s[elem],
            qv=-qa * s[elem] + qb * c[elem], qw=qw, voff=voff, m6=m6, vx=vx, vy=vy, ia=ia,
            ib=ib, zsize=int(zsize))
        self.bodies = FloatingBodies(free=free, phi=phi, cphi=c, sphi=s, h=h, draft=draft,
                                     area=area, J1=J1, J2=J2, load=np.zeros(n),
                                     rho_g=rho_w * g,
                                     **self._coefficients(ctx, free, phi, h, draft, area, J1,
                                                          J2, rho_i, rho_w, g, where))
        self._periods()
        self.kap = np.zeros((0, 0, 3, 2))
        if p["diffraction"]:
            if self.coefficients_used != "capytaine" or self.field is None:
                raise SceneError(f"{where}: diffraction = true needs coefficients = "
                                 "'capytaine' and a wave field in a [[forcing]] table")
            from .hydro import diffraction_factors

            self.kap = diffraction_factors(self.bodies, self.points, self.field, p, ctx,
                                           rho_w, g, where)
        for item in p["loads"]:
            ok = (isinstance(item, list) and len(item) == 2 and isinstance(item[0], int)
                  and 0 <= item[0] < n and isinstance(item[1], (int, float)))
            if not ok:
                raise SceneError(f"{where}: loads: each item is [element index, force in N] "
                                 f"with an index below {n}; got {item!r}")
            self.bodies.load[item[0]] += float(item[1])
        self.beams = None
        if p["bending"]:
            if ctx.contacts is None or not ctx.contacts.n_joints:
                raise SceneError(f"{where}: bending = true needs jointed elements (a "
                                 "[contact] table whose elements are frozen together)")
            if ctx.contacts.joint_slots > ctx.contacts.n_joints:
                raise SceneError(f"{where}: bending = true bends the joints built at the start "
                                 "only; a process here creates joints (refreeze weld = true): "
                                 "use one or the other")
            from .bending import Beams

            self.beams = Beams(self.bodies, ctx)
            self._periods()
            self.reads_contacts = True  # (on ranks: the ghosts' fields from their owners)
        self.memory = None
        if p["radiation"] == "memory":
            from siku_core.ice import process_schedule

            from .memory import Memory

            bod = self.bodies
            self.memory = Memory(p, bod, ctx, self._inertia, (bod.C3, bod.C1, bod.C2), where)
            every = 1
            tab = str(getattr(self, "table", ""))
            if tab.startswith("process[") and tab.endswith("]"):
                every = process_schedule(ctx.scene.cfg.process[int(tab[8:-1])].every,
                                         ctx.dt, where)
            dt_p = every * ctx.dt
            # A_inf (so the period) first from a fine kernel, then the kernel of the sub-steps
            self.memory.build(self.bodies, math.pi / (4 * self.memory.bands[0][0][-1]),
                              p["memory_tol"], where)
            self._periods()
            n_sub = max(1, math.ceil(dt_p * p["steps_per_period"] / self.period_min - 1e-9))
            self.memory.build(self.bodies, dt_p / n_sub, p["memory_tol"], where)
            self.memory.n_sub, self.memory.dt_p = n_sub, dt_p
            self._periods()
        if free.any():
            n_sub = self.memory.n_sub if self.memory is not None else self.substeps(ctx, ctx.dt)
            span = self.memory.dt_p if self.memory is not None else ctx.dt  # one step [s]

            def per_step(spp: float) -> int:  # sub-steps in one step with spp of them a period
                if spp == p["steps_per_period"]:
                    return n_sub
                return max(1, math.ceil(span * spp / self.period_min - 1e-9))

            check_work(where, "steps_per_period", p["steps_per_period"], per_step, ctx.n_steps,
                       least=self.params["steps_per_period"].min, dt=ctx.dt)
        self._floats, self._loaded = bool(free.any()), bool(self.bodies.load.any())
        self._wave_rec = None
        # the start: every free element at the scene's initial heave and tilts
        f = ctx.fields
        for key in ("heave", "roll", "pitch"):
            f[key][free] = p[f"initial_{key}"]

    def setup_on_rank(self, ctx, run, link) -> None:
        """On an MPI rank (``siku_core.ranks``): the run's set-up (``run``, over every
        element) for the elements the rank holds, ``link.ids``: their rows of its bodies,
        quadrature points, diffraction factors, loads and radiation memory, and its shortest
        period, so that every rank takes the run's sub-steps. With ``bending = true`` the
        beams are the rank's joints' (an owned element has all its joints here, and its row
        of their stiffness is the run's: ``siku_plugins.floating.bending``), and the ghosts
        take their owners' heave and tilts after each sub-step's drift (``link.to_ghosts``),
        so that an owned element's beams pull on the state its partners have on one rank."""
        ids = link.ids
        self.link = link
        self.field, self.exchange = run.field, run.exchange
        self.coefficients_used = run.coefficients_used
        self.bodies = type(run.bodies)(*(_rows_of(a, ids, run.bodies.free)
                                         for a in run.bodies))
        self._inertia = tuple(a[ids] for a in run._inertia)
        self.points = _points_of(run.points, ids)
        self.kap = run.kap[ids] if len(run.kap) else run.kap
        self.period_min = run.period_min
        self.memory = None
        if run.memory is not None:
            mem = copy.copy(run.memory)
            mem.kidx = run.memory.kidx[ids]
            mem.hist = run.memory.hist[ids].copy()
            self.memory = mem
        self.beams = None
        if run.beams is not None:
            from .bending import Beams

            self.beams = Beams(self.bodies, ctx)
            self.reads_contacts = True
        self._floats, self._loaded = run._floats, run._loaded
        self._wave_rec = None

    def _ghosts(self):
        """After each bonded sub-step's drift on an MPI rank: the ghosts' state from their
        owners (``None``: on one rank, or no beams). Every rank exchanges alike, with ghosts
        or without (a collective call)."""
        if self.beams is None or self.link is None:
            return None
        return self.link.to_ghosts

    def _coefficients(self, ctx, free, phi, h, d, A, J1, J2, rho_i, rho_w, g, where) -> dict:
        """The masses, damping and stiffnesses of :data:`FloatingBodies` (by name)."""
        p = self.p
        st = ctx.state
        m = rho_i * h * A
        C3 = rho_w * g * A
        C1 = rho_w * g * (J1 - A * d * (h - d) / 2.0)
        C2 = rho_w * g * (J2 - A * d * (h - d) / 2.0)
        bad = free & ~((C1 > 0) & (C2 > 0))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise SceneError(f"{where}: element {i} (thickness {h[i]:g} m, area {A[i]:g} m2) "
                             "would capsize alone: its metacentric height is not positive; "
                             "use elements wider than about twice their thickness")
        I1 = rho_i * h * J1 + m * h * h / 12.0
        I2 = rho_i * h * J2 + m * h * h / 12.0
        self._inertia = (m, I1, I2)
        kind = self._choose(ctx, free, phi, h, d)
        self.coefficients_used = kind
        if kind == "capytaine":
            from .hydro import element_coefficients

            omega = None
            if p["frequency"] == "wave" or p["coefficients"] == "auto":
                if self.field is None:
                    raise SceneError(f"{where}: frequency = 'wave' needs a wave field in a "
                                     "[[forcing]] table")
                omega = float(self.field.omega[np.argmax(self.field.amp)])
            A33, B33, A1, B1, A2, B2 = element_coefficients(
                st, free, phi, h, d, m, I1, I2, C3, C1, C2, rho_w, g,
                p["hydro_cache"], p["mesh_size"], omega, ctx.scene.base_dir, where)
        else:
            A33 = p["added_mass"] * rho_w * A ** 1.5
            A1 = p["added_inertia"] * rho_w * np.sqrt(A) * J1
            A2 = p["added_inertia"] * rho_w * np.sqrt(A) * J2
            B33 = 2 * p["damping_ratio"] * np.sqrt((m + A33) * C3)
            B1 = 2 * p["tilt_damping_ratio"] * np.sqrt((I1 + A1) * C1)
            B2 = 2 * p["tilt_damping_ratio"] * np.sqrt((I2 + A2) * C2)
            if kind == "small_body":
                from .small_body import KA_MAX, coefficients

                if self.field is None:
                    raise SceneError(f"{where}: coefficients = 'small_body' needs a wave "
                                     "field in a [[forcing]] table (its frequency)")
                fld = self.field
                omega = float(fld.omega[np.argmax(fld.amp)])
                *sb, ka = coefficients(A, J1, J2, m, I1, I2, C3, C1, C2, omega, rho_w, g,
                                       float(getattr(fld, "h", math.inf)))
                ok = ka <= KA_MAX   # beyond: the natural-frequency fit above
                for arr, new in zip((A33, B33, A1, B1, A2, B2), sb):
                    arr[ok] = new[ok]
        return {"M3": m + A33, "B3": B33, "C3": C3, "M1": I1 + A1, "B1": B1, "C1": C1,
                "M2": I2 + A2, "B2": B2, "C2": C2}

    def _choose(self, ctx, free, phi, h, d) -> str:
        """The coefficients ``coefficients = "auto"`` stands for (its parameter's help), or
        the one the scene names."""
        kind = self.p["coefficients"]
        if kind != "auto":
            return kind
        given = any(self.p[k] != self.params[k].default for k in (
            "added_mass", "damping_ratio", "added_inertia", "tilt_damping_ratio"))
        if given or self.field is None or not free.any() \
                or not len(self.field.amp):
            return "scene"
        try:
            import capytaine  # noqa: F401
        except ImportError:
            return "small_body"
        from .hydro import distinct_shapes

        if distinct_shapes(ctx.state, free, phi, h, d) > AUTO_CAPYTAINE_SHAPES:
            return "small_body"
        return "capytaine"

    def _periods(self) -> None:
        self.period_min = shortest_period(self.bodies, getattr(self, "beams", None))

    def _wave(self, ctx) -> None:
        """The wave field of the first ``[[forcing]]`` table that has one (module docstring),
        built from the same table (so the same sea the horizontal forcing feels)."""
        self.field = None
        self.exchange = None
        if self.p["wave"] == "exchange":
            if not any(f.source == "exchange" for f in ctx.scene.cfg.forcing):
                raise SceneError(f"{ctx.where(self.table)}: process 'floating': wave = "
                                 "'exchange' needs a [[forcing]] table with source = "
                                 "\"exchange\" (and [coupling.grid])")
            return
        if self.p["wave"] in ("none", "exchange"):
            return
        for k, f in enumerate(ctx.scene.cfg.forcing):
            if f.field is None:
                continue
            field = ctx.component("field", f.field.type, f.field.params,
                                  f"forcing[{k}].field")
            if not hasattr(field, "components") or not hasattr(field, "plane"):
                continue
            if getattr(field, "local_sea", False):
                # a sea that evolves (``spectral``): the forcing's own instance, whose spectrum
                # the run advances, so the elements float in the sea their cells hold now
                self.field = ctx.forcing_field(k)
                return
            field.setup(ctx)
            self.field = field
            return

    def couple_exchange(self, exchange) -> None:
        """Take the incident wave from ``exchange`` (the ``exchange`` forcing source whose
        fields a coupled model sets through the BMI; ``siku_io.coupling.bmi`` calls this) when
        ``wave = "exchange"``."""
        if self.p["wave"] == "exchange":
            self.exchange = exchange

    def exchange_load(self, ctx) -> np.ndarray:
        """``(n, 3)``: ``(∫ eta_d dA, ∫ u eta_d dA, ∫ v eta_d dA)`` of every element from the
        exchange grid (``wave = "exchange"``; ``(0, 3)`` otherwise): ``eta_d = p / (rho_w g)``
        where the coupled model gives the pressure ``p`` on the ice bottom, its elevation
        otherwise (module docstring)."""
        ex = self.exchange
        if ex is None:
            return _NO_EXT
        from .coupled import exchange_load

        return exchange_load(self.bodies, ctx, ex)

    # ------------------------------------------------------------------ the step
    def apply(self, ctx, dt: float) -> None:
        if dt <= 0.0 or not self._floats:
            return
        f = ctx.fields
        f["wave_radiated_power"][:] = 0.0     # the kernels write the free elements'
        st = ctx.state
        t0 = float(ctx.time - dt)
        if self.beams is not None or self._loaded:
            bm = self.beams
            if bm is not None and bm.stale():
                bm.assemble(self.bodies)   # joints broke (the law, a restart) since the last step
                self.period_min = min(self.period_min, bm.period_min)
            n_sub = self.substeps(ctx, dt)
            u = advance_jointed(n_sub, dt / n_sub, t0, st.q, self.field, self.bodies,
                                self.points, self.wave(ctx), bm, self.memory, f,
                                self._ghosts())
            if bm is not None and bm.break_overstressed(self.bodies, u,
                                                        self.p["flexural_strength"], ctx.time):
                self.period_min = min(self.period_min, bm.period_min)
            return
        n_sub = self.substeps(ctx, dt)
        mem = self.memory
        if mem is not None:
            from .memory import advance_modes

            advance_modes(n_sub, mem.dt, t0, st.q, self.bodies, self.points, self.wave(ctx),
                          mem.kernels(), motion(f))
            mem.head = (mem.head + n_sub) % mem.K.shape[2]
            return
        work = FLOAT_NS * (n_sub + 1)     # per element; below PARALLEL_MIN: one chunk
        nch = chunks(st.n, work) if st.n * work >= PARALLEL_MIN * ITEM_NS else 1
        advance(nch, n_sub, dt / n_sub, t0, st.q, self.bodies, self.points, self.wave(ctx),
                motion(f))

    def wave(self, ctx) -> tuple:
        """The incident wave now as the kernels take it, a :data:`FloatingWave` record: the
        wave field's components (none in still water), the amplitudes each element feels (a
        ``spectral`` field's ``sqrt(2 E_j)`` of the cell of its centre now, as the field's
        forces and breaking check use; else the incident ``amp``), the diffraction factors and
        the coupled model's loads (:meth:`exchange_load`)."""
        fld = self.field
        ext = self.exchange_load(ctx)
        n = ctx.state.n
        if fld is not None and getattr(fld, "local_sea", False):
            w = fld.plane_waves()
            return FloatingWave(
                lat0=w.lat0, lon0=w.lon0, R=w.R, depth=w.depth, ramp=float(self.p["ramp"]),
                amp=w.amp, kx=w.kx, ky=w.ky, omega=w.omega, phase=w.phase, k=w.k,
                acell=fld.amplitudes()[0], cell=fld.element_cells(ctx.state.q), kap=self.kap,
                ext=ext)
        rec = self._wave_rec
        if rec is None or rec.cell.shape[0] != n or (fld is not None and rec.amp is not fld.amp):
            w = fld.plane_waves() if fld is not None else None
            if w is None:
                none = np.zeros(0)
                rec = FloatingWave(lat0=0.0, lon0=0.0, R=1.0, depth=math.inf, ramp=0.0,
                                   amp=none, kx=none, ky=none, omega=none, phase=none, k=none,
                                   acell=np.zeros((1, 0)), cell=np.zeros(n, dtype=np.int64),
                                   kap=_NO_KAP, ext=ext)
            else:
                rec = FloatingWave(
                    lat0=w.lat0, lon0=w.lon0, R=w.R, depth=w.depth,
                    ramp=float(self.p["ramp"]), amp=w.amp, kx=w.kx, ky=w.ky, omega=w.omega,
                    phase=w.phase, k=w.k,
                    acell=np.ascontiguousarray(w.amp, dtype=float).reshape(1, -1).copy(),
                    cell=np.zeros(n, dtype=np.int64), kap=self.kap, ext=ext)
            self._wave_rec = rec
        return rec if rec.ext is ext else rec._replace(ext=ext)

    def substeps(self, ctx, dt: float) -> int:
        """The sub-steps of a step of ``dt`` [s]: at most ``T_min / steps_per_period`` each
        (module docstring), or those ``radiation = "memory"`` was set up for."""
        mem = self.memory
        if mem is None:
            return max(1, math.ceil(dt * self.p["steps_per_period"] / self.period_min - 1e-9))
        if dt != mem.dt_p:
            raise SceneError(f"{ctx.where(self.table)}: process 'floating': radiation = "
                             f"'memory' was set up for steps of {mem.dt_p:g} s, not {dt:g} s")
        return mem.n_sub

    def diagnostics(self, ctx):
        """``wave_radiated_power`` [W]: the radiation damping's power over all elements."""
        return {"wave_radiated_power": float(np.sum(ctx.fields["wave_radiated_power"]
                                                    * self.bodies.area))}

    def history(self):
        mem = self.memory
        return None if mem is None else {"rates": mem.hist.copy(), "head": np.array(mem.head)}

    def set_history(self, arrays) -> None:
        if self.memory is not None:
            self.memory.hist[:] = arrays["rates"]
            self.memory.head = int(arrays["head"])

    def equilibrium(self, ctx) -> np.ndarray:
        """The static state ``(n, 3)`` under the scene's ``loads`` in still water
        (``siku_plugins.floating.bending.equilibrium``): what a damped run settles to."""
        return equilibrium(self.bodies, self.beams, ctx.state.n)

    def stresses(self, ctx) -> np.ndarray:
        """Bending stress [Pa] at every joint line now (``bending = true``)."""
        return joint_stresses(self.bodies, self.beams, ctx.fields)

    def describe(self):
        out = super().describe()
        out["period_min"] = self.period_min if hasattr(self, "period_min") else None
        return out


def _rows_of(a, ids: np.ndarray, free: np.ndarray):
    """Rows ``ids`` of a per-element array of the run's bodies (a scalar as it is)."""
    return a[ids] if isinstance(a, np.ndarray) and a.shape[:1] == free.shape else a


def _points_of(pts, ids: np.ndarray):
    """The :data:`FloatingPoints` of the elements ``ids`` (ascending) of the run's ``pts``:
    their points and vertices, in the run's order."""
    def sel(off):
        counts = np.diff(off)[ids]
        new = np.zeros(len(ids) + 1, dtype=off.dtype)
        np.cumsum(counts, out=new[1:])
        rows = np.repeat(off[ids], counts) + (np.arange(new[-1]) - np.repeat(new[:-1], counts))
        return new, rows

    qoff, q = sel(pts.qoff)
    voff, v = sel(pts.voff)
    return type(pts)(qoff=qoff, qa=pts.qa[q], qb=pts.qb[q], qu=pts.qu[q], qv=pts.qv[q],
                     qw=pts.qw[q], voff=voff, m6=pts.m6[ids], vx=pts.vx[v], vy=pts.vy[v],
                     ia=pts.ia[q], ib=pts.ib[q], zsize=pts.zsize)


def _field_of(record: str, name: str, kind: str) -> property:
    return property(lambda self: getattr(getattr(self, record), name),
                    doc=f"``{record}.{name}`` (:data:`{kind}`), read-only")


# the records' fields by name, read-only, as the process's attributes of old
for _name in FloatingBodies._fields:
    setattr(Floating, _name, _field_of("bodies", _name,
                                       "siku_plugins.floating.kernels.FloatingBodies"))
for _name in ("qoff", "qa", "qb", "qu", "qv", "qw"):
    setattr(Floating, _name, _field_of("points", _name,
                                       "siku_plugins.floating.kernels.FloatingPoints"))
