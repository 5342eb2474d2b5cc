"""The sweep file's tables (``siku_io.ensemble.sweep`` reads the file): strict pydantic models, so
that an unknown key, an empty axis or zipped lists of unequal length are refused naming the key."""
from __future__ import annotations

import copy
import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

#: summary quantities computed from the snapshots rather than read from the diagnostics
DERIVED = {"mean_drift": ("m", "mean great-circle distance of the free elements from their "
                          "position at the first snapshot")}
#: names the summary dataset uses for its own variables: no axis may take them
RESERVED = ("time", "status", "message", "output", "command", "wall_time", "steps")


class _NoUnknownKeys(BaseModel):
    model_config = ConfigDict(extra="forbid")


class DrawCfg(_NoUnknownKeys):
    """A distribution to draw one key's values from."""

    distribution: Literal["uniform", "loguniform", "normal", "lognormal", "integers", "choice"]
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    std: float | None = Field(None, ge=0)
    sigma: float | None = Field(None, ge=0)
    values: list[Any] | None = None

    @model_validator(mode="after")
    def _needs(self) -> "DrawCfg":
        need = {"uniform": ("low", "high"), "loguniform": ("low", "high"),
                "integers": ("low", "high"), "normal": ("mean", "std"),
                "lognormal": ("mean", "sigma"), "choice": ("values",)}[self.distribution]
        given = {k for k in ("low", "high", "mean", "std", "sigma", "values")
                 if getattr(self, k) is not None}
        missing = [k for k in need if k not in given]
        extra = sorted(given - set(need))
        if missing or extra:
            raise ValueError(f"distribution '{self.distribution}' takes {', '.join(need)}"
                             + (f" (missing: {', '.join(missing)})" if missing else "")
                             + (f" (not used: {', '.join(extra)})" if extra else ""))
        if need == ("low", "high"):
            if not (math.isfinite(self.low) and math.isfinite(self.high)
                    and self.low < self.high):
                raise ValueError(f"give finite low < high (low = {self.low}, high = "
                                 f"{self.high})")
            if self.distribution == "loguniform" and self.low <= 0:
                raise ValueError(f"loguniform needs low > 0 (low = {self.low})")
        if self.distribution == "choice" and not self.values:
            raise ValueError("choice needs a non-empty list of values")
        return self

    def sample(self, rng: np.random.Generator, n: int) -> list[Any]:
        d = self.distribution
        if d == "uniform":
            x = rng.uniform(self.low, self.high, n)
        elif d == "loguniform":
            x = np.exp(rng.uniform(math.log(self.low), math.log(self.high), n))
        elif d == "normal":
            x = rng.normal(self.mean, self.std, n)
        elif d == "lognormal":
            x = rng.lognormal(self.mean, self.sigma, n)
        elif d == "integers":
            return [int(v) for v in rng.integers(int(self.low), int(self.high), n,
                                                 endpoint=True)]
        else:
            return [copy.deepcopy(self.values[int(k)]) for k in rng.integers(0, len(self.values),
                                                                            n)]
        return [float(v) for v in x]


class AxisCfg(_NoUnknownKeys):
    """``[[axis]]``: one dimension of the ensemble."""

    name: str | None = None
    key: str | None = None
    values: list[Any] | None = None
    zip: dict[str, list[Any]] | None = None
    draw: dict[str, DrawCfg] | None = None
    n: int | None = Field(None, ge=1, le=1_000_000)
    seed: int = Field(0, ge=0)

    @model_validator(mode="after")
    def _one_form(self) -> "AxisCfg":
        forms = [f for f in ("values", "zip", "draw") if getattr(self, f) is not None]
        if len(forms) != 1:
            raise ValueError("give exactly one of: key with values, zip, or draw with n")
        if self.values is not None:
            if not self.key:
                raise ValueError("'values' needs the 'key' they set")
            if not self.values:
                raise ValueError(f"key '{self.key}': empty list of values")
        elif self.key is not None:
            raise ValueError("'key' goes with 'values'; a zip or draw names its keys inside")
        if self.zip is not None:
            if not self.zip:
                raise ValueError("zip: give at least one key")
            lengths = {k: len(v) for k, v in self.zip.items()}
            first = next(iter(lengths))
            for k, n in lengths.items():
                if n == 0:
                    raise ValueError(f"zip key '{k}': empty list of values")
                if n != lengths[first]:
                    raise ValueError(f"zip key '{k}': {n} values, but '{first}' has "
                                     f"{lengths[first]}; zipped lists need equal lengths")
        if self.draw is not None:
            if not self.draw:
                raise ValueError("draw: give at least one key")
            if self.n is None:
                raise ValueError("draw needs n, the number of members to draw")
        elif self.n is not None:
            raise ValueError("'n' is the number of draws: it goes with 'draw'")
        return self


class ReplicatesCfg(_NoUnknownKeys):
    """``[replicates]``: the product again ``n`` times, replicate ``r`` with ``key = seed + r``."""

    n: int = Field(ge=1, le=1_000_000)
    key: str = "run.seed"
    seed: int = Field(0, ge=0)


class SummaryCfg(_NoUnknownKeys):
    """``[summary]``: the diagnostics of the summary dataset."""

    final: list[str] | None = None
    series: list[str] = Field(default_factory=list)
    file: str = "summary.nc"


class ClusterCfg(_NoUnknownKeys):
    """``[cluster]``: where the members run."""

    scheduler: str | None = None
    workers: int | None = Field(None, ge=1, le=4096)
    threads: int | None = Field(None, ge=1, le=4096)
    timeout: float = Field(10.0, gt=0, le=3600, description="time to reach a scheduler [s]")


class SweepCfg(_NoUnknownKeys):
    """The whole sweep file."""

    title: str = ""
    scene: str
    out_dir: str | None = None
    set: dict[str, Any] = Field(default_factory=dict)
    axis: list[AxisCfg] = Field(default_factory=list)
    replicates: ReplicatesCfg | None = None
    summary: SummaryCfg = Field(default_factory=SummaryCfg)
    cluster: ClusterCfg = Field(default_factory=ClusterCfg)
