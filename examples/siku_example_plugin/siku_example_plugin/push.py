"""A component that declares the plugin API versions it works with (``requires_api``): the
plugin guide's example of it (docs/howto/plugins.md, "The public surface"); not registered."""
from __future__ import annotations

from siku_core import Param
from siku_core.interfaces import ForcingSource


class UniformPush(ForcingSource):
    """A uniform push ``F = f`` [N] along each element's local x."""

    name = "uniform_push"
    requires_api = "1.x"  # any 1.*; "1.2": 1.2 or a later 1.*
    params = {"f": Param(1.0, "N", "force on each element")}

    def add(self, t, q, V, w, F, T):
        F[:, 0] += self.p["f"]
