"""The particle solvers' topology of several cables: which segment belongs to which cable (the gap from one cable's
last particle to the next one's first belongs to none), each cable's chain, the junctions' particles and the pairs
they make one point, and the braces of clamped junctions (:mod:`mjcable.solvers.junction_kernels`), as the state's
fields (:data:`~mjcable.solvers.kernels_layout.FIELDS`)."""

from __future__ import annotations

import numpy as np

from mjcable.scene import Scene

__all__ = ["topology"]


def topology(scene: Scene, *, frames: bool = False) -> dict:
    """The state's topology fields of ``scene``'s cables (:data:`~mjcable.solvers.kernels_layout.FIELDS`): the
    cable of each segment ``seg_cable`` (n,) (−1: the gap from one cable's last particle to the next one's first),
    each cable's segments ``chain_seg`` (C, 2) [first, stop), its μ ``cable_mu`` (C,), the junctions' particles
    ``junction_p`` (J, 2), their multipliers and force sums, the pairs of particles they join ``joined_p``, the
    particles' sums of the pooled friction cones between cables ``cable_load`` (N, 2), and the clamped junctions'
    braces ``brace_p`` (Q, 2) with their lengths ``brace_d`` (Q,) m (none with ``frames``: a rod with frames welds
    them, :func:`_rod_arrays`)."""
    slices = scene.cable_slices
    n = scene.n_particles - 1
    seg_cable = np.full(n, -1, dtype=np.int64)
    chain_seg = np.zeros((len(slices), 2), dtype=np.int64)
    for c, part in enumerate(slices):
        seg_cable[part.start:part.stop - 1] = c
        chain_seg[c] = part.start, part.stop - 1
    junction_p = np.array([scene.junction_particles(j) for j in range(len(scene.junctions))],
                          dtype=np.int64).reshape(-1, 2)
    brace_p = _braces(scene, junction_p) if not frames else np.zeros((0, 2), dtype=np.int64)
    x = np.asarray(scene.particles, dtype=np.float64)
    return dict(seg_cable=seg_cable, chain_seg=chain_seg,
                cable_mu=np.array([c.friction for c in scene.cables], dtype=np.float64), junction_p=junction_p,
                lam_j=np.zeros((len(junction_p), 3)), junction_sum=np.zeros((len(junction_p), 3)),
                joined_p=_joined_pairs(junction_p), cable_load=np.zeros((scene.n_particles, 2)), brace_p=brace_p,
                brace_d=np.linalg.norm(x[brace_p[:, 0]] - x[brace_p[:, 1]], axis=1))


def _braces(scene: Scene, junction_p: np.ndarray) -> np.ndarray:
    """``(Q, 2)`` the braces of ``scene``'s clamped junctions (``junction_p`` (J, 2) their particles): a neighbour of
    each joined particle along its cable, every such pair (:mod:`mjcable.solvers.junction_kernels`)."""
    slices = scene.cable_slices

    def neighbours(p):
        part = next(s for s in slices if s.start <= p < s.stop)
        return [q for q in (p - 1, p + 1) if part.start <= q < part.stop]

    pairs = [(p, q) for junction, (a, b) in zip(scene.junctions, junction_p.tolist()) if junction.clamp
             for p in neighbours(a) for q in neighbours(b) if p != q and p != b and q != a]
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


def _joined_pairs(junction_p: np.ndarray) -> np.ndarray:
    """``(M, 2)`` every pair of particles that the junctions ``junction_p`` (J, 2) make one point, directly or through
    other junctions (three cables joined by two junctions make three pairs)."""
    group = {}  # particle -> the set of particles at its point
    for a, b in junction_p.tolist():
        joined = group.get(a, {a}) | group.get(b, {b})
        for p in joined:
            group[p] = joined
    pairs = {(a, b) for members in map(frozenset, group.values()) for a in members for b in members if a < b}
    return np.array(sorted(pairs), dtype=np.int64).reshape(-1, 2)
