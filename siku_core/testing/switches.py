"""Switches of the contact phase for tests and benchmarks only: module-level settings, read by
:class:`~siku_core.contact.contact_model.ContactModel` where it uses them (set them before building
a
run, or before the evaluation they should change; ``monkeypatch.setattr(switches, ...)`` in
tests). A production run never changes them."""
from __future__ import annotations

#: skip the clip of pairs that :func:`~siku_core.geometry.clip.apart` finds apart or touching
#: (their overlap has no area); off only to test that claim
pretest = True
#: find the touching overlap of jointed neighbours from the joint's edges (``geometry.face``)
#: instead of clipping it; off only to measure what that changes (read when the candidate
#: list is indexed)
face_path = True
#: clip each overlapping pair from the edges its boundaries crossed at the last evaluation
#: (``geometry.coherent``: the same results to round-off) instead of in full; read when the
#: candidate list is indexed. Off until measured on an idle machine; restarts would differ at
#: round-off (the hints are not in the restart file): bench/RESULTS.md
coherent_clip = False
