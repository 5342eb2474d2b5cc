"""The stable time step of the contact phase: every stiffness and every damper an element feels.

The integrator (semi-implicit Euler: velocities from the forces of the old state, positions from
the new velocities) is stable for a linear system ``M x'' + C x' + K x = 0`` in a mode of
frequency ``omega`` and damping rate ``gamma = 2 zeta omega`` when

    omega² dt² + 2 gamma dt < 4,     i.e.  dt < dt_c = 4 / (gamma + sqrt(gamma² + 4 omega²))

(the Jury conditions of the mode's 2×2 amplification matrix: trace ``2 - gamma dt - omega²
dt²``, determinant ``1 - gamma dt``); without damping ``dt_c = 2 / omega``, with ``zeta = 1``
``0.83 / omega``. An explicit damper (acting on the old velocity) *lowers* the stable step; the
dampers of a law that bounds them by the step (``bounded_damping``,
:mod:`siku_core.contact.damping`)
satisfy ``dt C' < M`` and leave it at least ``sqrt(2) / omega``, close to ``2 / omega``.

:func:`contact_matrices` assembles the contact phase's stiffness ``K`` and damping ``C`` about
the state at rest, for the three degrees of freedom ``(x, y, theta)`` of every free element
(static and steady elements are walls):

* a joint: a spring of ``f K w`` along the joint's normal and ``s f K w`` along it (``f`` the
  law's ``stiffness_factor()``, ``s`` its ``joint_shear``: 1 for the distributed spring,
  ``1/(2(1 + nu))`` for Mohr–Coulomb and the bond) spread along the joint, exactly as two point
  springs of half that at the joint's Gauss points
  (which integrate the linear displacement profile of §5 of the contacts page exactly: force
  ``K w (s1 + s2)/2`` and couple ``K w³ theta / 12``), damped with ``2 zeta_j sqrt(f K w m)``
  spread the same way (``zeta_j`` the law's joint damping ratio, ``m`` the pair's reduced mass);
* under ``contact.jointed = "collide"`` the same pair also collides when pressed: a normal spring
  ``K w`` at the joint's middle, damped with ``2 zeta_c sqrt(K w m)``, counted under either
  ``touching`` rule (a pressed pair overlaps by more than round-off). This is the mode the
  element-wise bound used before missed: a jointed pair under compression is twice as stiff
  as its joint, and its two dampers add;
* every edge of an element without a joint: a collision budget ``h E`` along the edge's normal
  at its middle, against an unknown partner (taken as a wall: the reduced mass is the element's
  own), damped with ``zeta_c``.

The largest eigenvalues ``omega_max²`` of ``M^-1/2 K M^-1/2`` and ``gamma_max`` of ``M^-1/2 C
M^-1/2`` give ``dt_c`` by the formula above: dense for small systems; above :data:`DENSE_DOF`
free DOF by :func:`top_eigenvalue`, a fixed number of Lanczos steps on the never-formed
operators (``B^T diag(c) B``, six numbers per spring) capped by Gershgorin's bound, an
estimate from above within :data:`LANCZOS_TOL`, in time and memory linear in the contacts.
Where ``K`` and ``C`` share their modes (proportional damping, the joints alone) that is the
exact limit of the linear system, and taking the two maxima separately can only lower it; where
they do not, it is an estimate, checked against the exact spectral radius of the amplification
matrix on small packs (``tests/contacts/test_stable_step.py``). The engine then applies ``[run]
dt_safety`` (default 0.5) for what the linearisation at rest leaves out: contact widths that grow
with the overlap, the water drag's own limit (a separate component), damage.

With dampers bounded by the step (``bounded_damping``, :mod:`siku_core.contact.damping`), the
larger of that and ``sqrt(4 - 2 g) / omega_max``, ``g = h gamma'_max(h)`` the rate of the
dampers as they act at ``h = 2 / omega_max`` (:func:`critical_step`).

Not covered, and said by the law: the ``sqrt_area`` collision law has no bounded stiffness
(``dF/d(depth)`` grows without bound as the overlap vanishes); the estimate then takes the
linear law's ``K w`` and the engine warns.
"""
from __future__ import annotations

import math

import numpy as np

from .damping import critical_step as damped_step
from ..state import FREE

#: systems with at most this many free degrees of freedom are solved densely
DENSE_DOF = 600
#: relative tolerance of the sparse estimate of a largest eigenvalue (:func:`top_eigenvalue`):
#: it lies in ``[lambda_max, lambda_max / (1 - LANCZOS_TOL)]``, so ``dt_c`` is at most about
#: half of it below the exact limit
LANCZOS_TOL = 0.01
#: the probability at most that the sparse estimate falls below ``lambda_max``
LANCZOS_FAIL = 1e-6
#: Gauss points of a joint (z along the joint, from end a to end b)
_GAUSS = (0.5 - 0.5 / math.sqrt(3.0), 0.5 + 0.5 / math.sqrt(3.0))


def _perp(p: np.ndarray) -> np.ndarray:
    """``k × p`` for rows of 2-vectors: the displacement of point ``p`` per unit rotation."""
    return np.stack([-p[:, 1], p[:, 0]], axis=1)


class _Assembler:
    """A symmetric positive semi-definite matrix ``sum_k c_k b_k b_k^T`` over the 3 DOF per
    element, kept as its vectors: ``B`` (one sparse row ``b_k`` per vector, entries on walls
    dropped) and the coefficients ``c_k``. A vector of ``w`` entries costs ``w`` numbers here
    against the ``w²`` triplets of its outer product (36 for a point of a joint)."""

    def __init__(self, n: int, free: np.ndarray):
        self.n = n
        self.free = free
        self.itype = np.int32 if 3 * n < 2**31 else np.int64
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add_vectors(self, coef, entries: list[tuple[np.ndarray, int, np.ndarray]]):
        """Add ``coef[k] b_k b_k^T`` where ``b_k`` has value ``v[k]`` at DOF ``3 e[k] + d`` for
        every ``(e, d, v)`` of ``entries``; entries on walls are left out (fixed DOF)."""
        m = len(entries[0][0])
        cols = np.empty((m, len(entries)), dtype=self.itype)
        vals = np.empty((m, len(entries)))
        for c, (e, d, v) in enumerate(entries):
            cols[:, c] = 3 * e + d
            vals[:, c] = np.where(self.free[e], v, 0.0)
        self.parts.append((np.broadcast_to(np.asarray(coef, dtype=float), (m,)), cols, vals))

    def factors(self, scale: np.ndarray | None = None, consume: bool = False):
        """``(B, c)``: the vectors as a CSR matrix (one row each, ``3 n`` columns; column ``i``
        times ``scale[i]`` if given) and their coefficients. ``consume``: each family of
        vectors is let go as soon as it is copied (the assembler is left empty), so that the
        copy never sits beside all of them: the peak memory of the build's stable-step check
        is about one copy of the vectors, not two."""
        from scipy.sparse import csr_matrix

        n3 = 3 * self.n
        parts = self.parts
        if consume:
            self.parts = []
        width = max((p[1].shape[1] for p in parts), default=1)
        m = sum(len(p[0]) for p in parts)
        itype = self.itype if m * width < 2**31 else np.int64
        cols = np.zeros((m, width), dtype=itype)
        vals = np.zeros((m, width))
        coef = np.empty(m)
        r = 0
        for at in range(len(parts)):
            c, pc, pv = parts[at]
            if consume:
                parts[at] = None
            k, w = pc.shape
            cols[r:r + k, :w] = pc
            # (scaled family by family: the products of the whole array, without its copy)
            vals[r:r + k, :w] = pv if scale is None else pv * scale[pc]
            coef[r:r + k] = c
            r += k
            del c, pc, pv
        B = csr_matrix((vals.ravel(), cols.ravel(), np.arange(0, m * width + 1, width,
                                                                 dtype=itype)), shape=(m, n3))
        return B, coef

    def matrix(self):
        """The matrix itself (scipy CSR, ``3 n`` square)."""
        from scipy.sparse import csr_matrix, diags

        if not self.parts:
            return csr_matrix((3 * self.n, 3 * self.n))
        B, c = self.factors()
        A = (B.T @ diags(c) @ B).tocsr()
        A.eliminate_zeros()
        return A

    def gram(self, scale: np.ndarray) -> "Gram":
        """The matrix scaled on both sides, ``S A S`` (``S = diag(scale)``), as a
        :class:`Gram` operator (never formed); the assembler's own copy is let go."""
        return Gram(*self.factors(scale, consume=True))


class _Unwanted:
    """An assembler not asked for (``contact_matrices(which=...)``): its vectors are dropped."""

    def add_vectors(self, coef, entries) -> None:
        return None


class Gram:
    """``A = B^T diag(c) B`` (``c >= 0``) as an operator: ``A x`` in ``O(nnz(B))`` time and no
    more memory than ``B``."""

    def __init__(self, B, c: np.ndarray):
        self.B = B
        self.c = c
        self.n = B.shape[1]

    def matvec(self, x: np.ndarray) -> np.ndarray:
        return self.B.T @ (self.c * (self.B @ x))

    def gershgorin(self) -> np.ndarray:
        """Row sums of ``|B|^T diag(c) |B|``, each at least that of ``|A|``: their largest
        bounds the largest eigenvalue from above (Gershgorin)."""
        from scipy.sparse import csr_matrix

        B = self.B  # (|B| shares B's indices: a copy of its values only)
        absB = csr_matrix((np.abs(B.data), B.indices, B.indptr), shape=B.shape)
        return absB.T @ (self.c * (absB @ np.ones(self.n)))


def _point_entries(i, j, p_i, p_j, rot, d_i):
    """Entries of ``b = d · (relative displacement of j's point p_j against i's point p_i)``,
    ``d_i`` a direction in ``i``'s frame, ``rot`` the rotation (cos, sin) taking ``j``'s frame
    to ``i``'s. Returns the ``(element, dof, value)`` list."""
    c, s = rot
    # the direction in j's frame: R^T d
    dj = np.stack([c * d_i[:, 0] + s * d_i[:, 1], -s * d_i[:, 0] + c * d_i[:, 1]], axis=1)
    pi_perp = _perp(p_i)
    pj_perp = _perp(p_j)
    return [
        (i, 0, -d_i[:, 0]), (i, 1, -d_i[:, 1]), (i, 2, -np.sum(d_i * pi_perp, axis=1)),
        (j, 0, dj[:, 0]), (j, 1, dj[:, 1]), (j, 2, np.sum(dj * pj_perp, axis=1)),
    ]


def contact_matrices(model, rates: dict, edges: bool = True, factored: bool = False,
                     dt: float | None = None, which: str = "KC"):
    """Stiffness and damping matrices (scipy CSR, ``3 n`` square, N/m, N m/rad, ...) of the
    contact phase of ``model`` (a :class:`~siku_core.contact.contact_model.ContactModel`) at rest.

    ``dt`` [s]: the dampers as they act in a step of ``dt`` where the law's are bounded
    (``rates["bounded_damping"]``: each ``c`` becomes :func:`~siku_core.contact.damping.step_damper`
    of it, with the engine's ``1/m_d`` at the contact's lever arms); ``None``: as written
    (explicit), the rates the estimate reads.

    ``rates`` are the law's :meth:`~siku_core.contact_law.ContactLaw.stability_rates`. Joints
    that have broken count as free edges (their pair collides as independent elements);
    ``edges = False`` leaves the free edges' collision budget out (the contacts of the state at
    rest alone); ``factored = True`` returns the two as their vectors and coefficients
    (:class:`_Assembler`: ``factors``, ``gram``, ``matrix``), never formed. ``which``: the
    ones wanted, ``"K"``, ``"C"`` or both; the other is ``None`` (assembled one at a time, a
    large pack's check holds one set of vectors at once)."""
    st = model.state
    n = st.n
    free = st.flags == FREE
    KA = _Assembler(n, free) if "K" in which else _Unwanted()
    CA = _Assembler(n, free) if "C" in which else _Unwanted()
    zc = float(rates.get("collision_damping", 0.0))
    zj = float(rates.get("joint_damping", 0.0))
    fj = float(rates.get("joint_stiffness", 1.0))
    fc = float(rates.get("collision_stiffness", 1.0))
    collide = not model.exclude_jointed
    joints = model.n_joints and model.law.uses_joints
    bound = dt is not None and bool(rates.get("bounded_damping", False))
    dmob = model.damping_mobility()

    def damper(c, e_i, r2_i, e_j=None, r2_j=None):
        """``c`` as it acts in a step of ``dt`` (``siku_core.contact.damping``)."""
        if not bound:
            return c
        lam = dmob[e_i, 0] + r2_i * dmob[e_i, 1]
        if e_j is not None:
            lam = lam + dmob[e_j, 0] + r2_j * dmob[e_j, 1]
        return step_damper_array(c, dt * lam)

    jointed_edges = np.zeros(n, dtype=np.int64)
    if joints:
        k = np.flatnonzero(model.intact)
        ji, jj = model.ji[k], model.jj[k]
        ei, ej = model.ends_i[k], model.ends_j[k]
        w = model.width[k]
        K = model.jK[k]
        meff = model.jmeff[k]
        ti, tj = ei[:, 1] - ei[:, 0], ej[:, 1] - ej[:, 0]
        ang = np.arctan2(ti[:, 1], ti[:, 0]) - np.arctan2(tj[:, 1], tj[:, 0])
        rot = (np.cos(ang), np.sin(ang))
        kj = fj * K * w
        r2i = np.maximum(np.sum(ei[:, 0]**2, axis=1), np.sum(ei[:, 1]**2, axis=1))
        r2j = np.maximum(np.sum(ej[:, 0]**2, axis=1), np.sum(ej[:, 1]**2, axis=1))
        cj = damper(2.0 * zj * np.sqrt(kj * meff), ji, r2i, jj, r2j)
        shear = rates.get("joint_shear", 1.0)
        share = 1.0 / (2.0 * (1.0 + model.nu[ji])) if shear == "poisson" else float(shear)
        if rates.get("joint_shear_damping", "normal") == "own":
            # its own damper, bounded on its own (siku_core.contact.damping), as a share of cj
            craw = 2.0 * zj * np.sqrt(kj * meff)
            cshare = damper(craw * np.sqrt(share), ji, r2i, jj, r2j) / np.maximum(cj, 1e-300)
        else:
            cshare = np.ones(len(k))
        tan = ti / np.maximum(w, 1e-300)[:, None]
        nrm = np.stack([tan[:, 1], -tan[:, 0]], axis=1)
        for z in _GAUSS:
            pi = ei[:, 0] + z * ti
            pj = ej[:, 0] + z * tj
            for d, sk, sc in ((nrm, 1.0, 1.0), (tan, share, cshare)):
                ent = _point_entries(ji, jj, pi, pj, rot, d)
                KA.add_vectors(0.5 * kj * sk, ent)
                CA.add_vectors(0.5 * cj * sc, ent)
        if collide:
            mi, mj = ei[:, 0] + 0.5 * ti, ej[:, 0] + 0.5 * tj
            ent = _point_entries(ji, jj, mi, mj, rot, nrm)
            kc = fc * K * w
            KA.add_vectors(kc, ent)
            CA.add_vectors(damper(2.0 * zc * np.sqrt(kc * meff), ji, np.sum(mi**2, axis=1), jj,
                                  np.sum(mj**2, axis=1)), ent)
        np.add.at(jointed_edges, ji, 1)
        np.add.at(jointed_edges, jj, 1)
    # free edges: a collision budget h E against a wall at the edge's middle, along its normal
    off = st.vert_offsets
    nedge = np.diff(off)
    budget = np.maximum(nedge - jointed_edges, 0)
    e_rows = np.flatnonzero(free & (budget > 0)) if edges else np.zeros(0, dtype=np.int64)
    if len(e_rows):
        # the budget goes on the element's edges of largest lever arm (the worst for rotation):
        # h E on each of its (edges - joints) edges
        owner = np.repeat(np.arange(n), nedge)
        nxt = np.arange(len(st.verts)) + 1
        last = off[1:] - 1
        nxt[last[nedge > 0]] = off[:-1][nedge > 0]
        va, vb = st.verts, st.verts[nxt]
        mid_all = 0.5 * (va + vb)
        t = vb - va
        ln = np.hypot(t[:, 0], t[:, 1])
        nn_all = np.stack([t[:, 1], -t[:, 0]], axis=1) / np.maximum(ln, 1e-300)[:, None]
        lever = np.abs(mid_all[:, 0] * nn_all[:, 1] - mid_all[:, 1] * nn_all[:, 0])
        order = np.lexsort((np.arange(len(lever)), -lever, owner))
        rank = np.arange(len(order)) - off[owner[order]]
        take = order[(rank < budget[owner[order]]) & (free & (budget > 0))[owner[order]]]
        el = owner[take]
        mid = mid_all[take]
        nrm = nn_all[take]
        kb = fc * st.thickness[el] * model.E[el]
        ent = [(el, 0, nrm[:, 0]), (el, 1, nrm[:, 1]),
               (el, 2, np.sum(nrm * _perp(mid), axis=1))]
        KA.add_vectors(kb, ent)
        CA.add_vectors(damper(2.0 * zc * np.sqrt(kb * st.m[el]), el, np.sum(mid**2, axis=1)),
                       ent)
    out = tuple(None if isinstance(A, _Unwanted) else A if factored else A.matrix()
                for A in (KA, CA))
    return out


def lanczos_steps(m: int, tol: float = LANCZOS_TOL, fail: float = LANCZOS_FAIL) -> int:
    """Lanczos steps that bring the largest Ritz value of an ``m``-square positive
    semi-definite matrix within ``tol`` of its largest eigenvalue but with probability
    ``fail`` at most, from a random start: Kuczyński & Woźniakowski (1992, SIAM J. Matrix Anal.
    Appl. 13, 1094, Theorem 4.2), ``P(theta_k < (1 - tol) lambda_max) <= 1.648 sqrt(m)
    exp(-sqrt(tol) (2 k - 1))``. About 100 for ``m = 10^5`` at the defaults."""
    k = 0.5 * (1.0 + math.log(1.648 * math.sqrt(max(m, 1)) / fail) / math.sqrt(tol))
    return max(1, min(m, math.ceil(k)))


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """``a · b`` without BLAS (whose threads, spinning on a vector this short, cost twenty
    times the work on a busy machine)."""
    return float(np.einsum("i,i->", a, b))


def _lanczos(op: "Gram", steps: int, start: np.ndarray, ritz: np.ndarray | None = None):
    """``steps`` Lanczos steps on ``op`` from ``start`` (three vectors kept, no basis): the
    tridiagonal's diagonal and off-diagonal, and (``ritz`` given, coefficients over the basis)
    the vector ``sum_j ritz[j] q_j`` built as the same steps pass again. Stops early where the
    Krylov space closes (an invariant subspace: its Ritz values are exact)."""
    q = start / math.sqrt(_dot(start, start))
    q_prev = np.zeros_like(q)
    beta = 0.0
    alpha: list[float] = []
    betas: list[float] = []
    x = None if ritz is None else np.zeros_like(q)
    for j in range(steps):
        if x is not None:
            x += ritz[j] * q
        w = op.matvec(q)
        a = _dot(q, w)
        w -= a * q + beta * q_prev
        w -= _dot(q, w) * q  # keeps the local orthogonality of q_j and q_j+1
        alpha.append(a)
        beta = math.sqrt(_dot(w, w))
        if j == steps - 1 or beta <= 1e-13 * max(abs(a), 1e-300):
            break
        betas.append(beta)
        q_prev, q = q, w / beta
    return np.array(alpha), np.array(betas), x


def top_eigenvalue(op: "Gram", tol: float = LANCZOS_TOL, fail: float = LANCZOS_FAIL,
                   seed: int = 0) -> tuple[float, np.ndarray]:
    """An upper estimate of the largest eigenvalue of the positive semi-definite ``op`` (a
    :class:`Gram`) and its vector, in time and memory linear in its size.

    :func:`lanczos_steps` steps from a random start (seeded: the same answer every time) give
    the Ritz value ``theta <= lambda_max``; the answer is ``min(theta / (1 - tol), G)``, ``G``
    Gershgorin's bound (:meth:`Gram.gershgorin`, never below ``lambda_max``). So it never
    exceeds ``lambda_max / (1 - tol)``, and lies below ``lambda_max`` with probability ``fail``
    at most (in exact arithmetic; rounding only clusters copies of converged Ritz values,
    Paige 1976); ``G`` also answers where the iteration fails. The Ritz vector is rebuilt by
    a second pass of the same steps instead of keeping the Krylov basis."""
    from scipy.linalg import eigh_tridiagonal

    rows = op.gershgorin()
    bound = float(rows.max()) if op.n else 0.0
    if not bound > 0.0:
        return 0.0, np.zeros(op.n)
    fallback = (rows == bound).astype(float)  # the DOF of Gershgorin's largest row
    start = np.random.default_rng(seed).standard_normal(op.n)
    alpha, beta, _ = _lanczos(op, lanczos_steps(op.n, tol, fail), start)
    try:
        vals, vecs = eigh_tridiagonal(alpha, beta)
    except (ValueError, np.linalg.LinAlgError):
        return bound, fallback
    theta = float(vals[-1])
    if not math.isfinite(theta) or theta / (1.0 - tol) >= bound:
        return bound, fallback
    _, _, vec = _lanczos(op, len(alpha), start, ritz=vecs[:, -1])
    return max(theta, 0.0) / (1.0 - tol), vec


def step_damper_array(c: np.ndarray, dtm: np.ndarray) -> np.ndarray:
    """:func:`siku_core.contact.damping.step_damper` on arrays."""
    return np.where(c * dtm > 1.0, 1.0 / np.where(dtm > 0.0, dtm, 1.0), c)


def _largest(A, dof: np.ndarray) -> tuple[float, np.ndarray]:
    """Largest eigenvalue of the symmetric positive semi-definite ``A`` (dense: its
    restriction to ``dof``) and the square of its eigenvector over all DOF (zeros where ``A``
    is empty). ``A`` is an :class:`_Assembler`'s :class:`Gram` operator, or for at most
    :data:`DENSE_DOF` free DOF the matrix (solved densely)."""
    share = np.zeros(A.shape[0] if not isinstance(A, Gram) else A.n)
    if isinstance(A, Gram):
        lam, vec = top_eigenvalue(A)
        share[:] = vec * vec
        return lam, share
    sub = A[dof][:, dof]
    if len(dof) == 0 or sub.nnz == 0:
        return 0.0, share
    vals, vecs = np.linalg.eigh(sub.toarray())
    share[dof] = vecs[:, -1] ** 2
    return float(max(vals[-1], 0.0)), share


def critical_step(model, rates: dict) -> tuple[float, int, dict]:
    """``(dt_c [s], element, details)`` of the contact phase of ``model``: the stable step of
    its linearisation at rest (module docstring), the element that moves most in the stiffest
    mode, and ``details`` (``omega`` [rad/s], ``gamma`` [1/s], the mode's element).

    Up to :data:`DENSE_DOF` free DOF the eigenvalues are exact (dense); above, the operators
    are never formed and :func:`top_eigenvalue` estimates each from above within
    :data:`LANCZOS_TOL` (``dt_c`` then within about half that below the exact one), in time and
    memory linear in the number of contacts."""
    st = model.state
    free = st.flags == FREE
    if not free.any():
        return math.inf, -1, {"omega": 0.0, "gamma": 0.0}
    mass = np.stack([st.m, st.m, st.I], axis=1).ravel()
    dof = np.flatnonzero(np.repeat(free, 3))
    s = 1.0 / np.sqrt(mass)
    def largest(A):
        """The largest eigenvalue of ``M^-1/2 A M^-1/2`` and its DOF shares."""
        if len(dof) <= DENSE_DOF:
            from scipy.sparse import diags

            D = diags(s)
            return _largest(D @ A.matrix() @ D, dof)
        return _largest(A.gram(s), dof)

    # one assembled at a time (each let go by its estimate): the check's peak memory is one set
    om2, vec = largest(contact_matrices(model, rates, factored=True, which="K")[0])
    gam, cvec = largest(contact_matrices(model, rates, factored=True, which="C")[1])
    if om2 <= 0.0 and gam <= 0.0:
        return math.inf, -1, {"omega": 0.0, "gamma": 0.0}
    bounded = bool(rates.get("bounded_damping", False))
    dt_c = damped_step(math.sqrt(om2), gam, bounded)
    details = {"omega": math.sqrt(om2), "gamma": gam}
    if bounded and om2 > 0.0:
        # the dampers as they act at the undamped limit h = 2/omega: their largest rate
        # gamma'(h) there gives g = h gamma'(h), which only grows with the step (each
        # c' h = c h / (1 + c h / m_d) does); so at dt = sqrt(4 - 2 g) / omega <= h the
        # condition omega² dt² + 2 dt gamma'(dt) <= 4 holds
        h = 2.0 / math.sqrt(om2)
        gb, bvec = largest(contact_matrices(model, rates, factored=True, dt=h, which="C")[1])
        g = h * gb
        bounded_dt = math.sqrt(4.0 - 2.0 * g) / math.sqrt(om2) if g < 2.0 else 0.0
        details["gamma_bounded"] = gb
        if bounded_dt > dt_c:
            dt_c = bounded_dt
            gam, cvec = gb, bvec
    # the element of the stiffest mode (of the damping's, when the damping sets the step)
    share = vec if om2 * dt_c * dt_c >= 2.0 * gam * dt_c else cvec
    elem = int(np.argmax(share.reshape(-1, 3).sum(axis=1)))
    return dt_c, elem, details


def gershgorin_bound(cm) -> tuple[float, int]:
    """Largest ``omega`` [rad/s] by a Gershgorin bound over each element's contacts.

    Per element: joints contribute ``K w`` (translation) and ``K w (r² + w²/12)`` (rotation),
    edges without a joint a collision budget of ``h E`` each. ``omega² <= 2 k_sum / m`` and
    ``2 k_rot / I``. Returns ``(omega_max, element)``; ``cm``: the
    :class:`~siku_core.contact.contact_model.ContactModel`.
    """
    st = cm.state
    n = st.n
    ktr = np.zeros(n)
    krot = np.zeros(n)
    njoint = np.zeros(n)
    if cm.n_joints and cm.law.uses_joints:
        mid_i = 0.5 * (cm.ends_i[:, 0] + cm.ends_i[:, 1])
        mid_j = 0.5 * (cm.ends_j[:, 0] + cm.ends_j[:, 1])
        ri = np.hypot(*mid_i.T)
        rj = np.hypot(*mid_j.T)
        hi, hj = st.thickness[cm.ji], st.thickness[cm.jj]
        Ei, Ej = cm.E[cm.ji], cm.E[cm.jj]
        K = hi * Ei * hj * Ej / (hi * Ei * rj + hj * Ej * ri)
        k = K * cm.width * cm.law.stiffness_factor()
        np.add.at(ktr, cm.ji, k)
        np.add.at(ktr, cm.jj, k)
        np.add.at(krot, cm.ji, k * (ri**2 + cm.width**2 / 12))
        np.add.at(krot, cm.jj, k * (rj**2 + cm.width**2 / 12))
        np.add.at(njoint, cm.ji, 1)
        np.add.at(njoint, cm.jj, 1)
    nedge = np.diff(st.vert_offsets)
    free_edges = np.maximum(nedge - njoint, 0)
    kc = free_edges * st.thickness * cm.E
    ktr += kc
    krot += kc * st.radius**2
    free = st.flags == FREE
    if not free.any():
        return 0.0, -1
    om2 = np.where(free, np.maximum(2 * ktr / st.m, 2 * krot / st.I), 0.0)
    i = int(np.argmax(om2))
    return math.sqrt(om2[i]), i


def limit_and_reason(law: str, d: dict, il: int, i: int) -> tuple[float, str]:
    """The contact phase's critical step [s] and what sets it, from the details ``d`` of
    :func:`critical_step` (its element ``il``) and the element-wise undamped bound
    ``d["undamped_bound"]`` (its element ``i``): the smaller of the two."""
    if d["linear"] < d["undamped_bound"]:
        damp = f"damping rate {d['gamma']:.4g} 1/s"
        if "gamma_bounded" in d:
            damp += f" as written, {d['gamma_bounded']:.4g} 1/s bounded by the step at 2/omega"
        return d["linear"], (f"stiffest mode at element {il} under law '{law}' (omega = "
                             f"{d['omega']:.4g} rad/s, undamped limit "
                             f"{2.0 / d['omega']:.4g} s; {damp})")
    return d["undamped_bound"], (f"stiffest contact of element {i} under law '{law}' (element "
                                 f"by element, undamped; the whole pack's estimate "
                                 f"{d['linear']:.4g} s)")
