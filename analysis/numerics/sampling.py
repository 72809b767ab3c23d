"""Sampling and sample statistics of the Monte Carlo studies (Pavlenko 2014, chapter 3).

Marginal distributions of the uncertain parameters (normal, uniform, lognormal, or the source's
sum of 12 uniforms ``gauss12``, Fig. 3.1), optionally correlated through a Gaussian copula; seeded,
chunked, reproducible draws; the per-column statistics the source reports (population mean and
standard deviation, coefficient of variation, bands mean +- k sigma) with quantiles, and their
Monte Carlo standard errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from autobal.errors import ScenarioError


@dataclass(frozen=True)
class Marginal:
    """One uncertain parameter, resolved: kind, mean and standard deviation of the parameter itself
    (uniform also low, high)."""

    name: str
    kind: str
    mean: float
    std: float
    low: float = math.nan
    high: float = math.nan

    def transform(self, z: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Samples from standard normal scores z (Gaussian copula); gauss12 draws its own uniforms."""
        if self.kind == "normal":
            return self.mean + self.std * z
        if self.kind == "lognormal":
            s2 = math.log1p((self.std / self.mean) ** 2)
            return self.mean * np.exp(math.sqrt(s2) * z - 0.5 * s2)
        if self.kind == "uniform":
            return self.low + (self.high - self.low) * ndtr(z)
        if self.kind == "gauss12":  # Fig. 3.1: x (1 + kappa (sum of 12 rnd(1) - 6))
            return self.mean + self.std * (rng.random((z.size, 12)).sum(axis=1) - 6.0)
        raise ValueError(f"unknown distribution {self.kind!r}")


def marginals(parameters: dict, nominal: dict, where: str = "analyses.montecarlo.parameters") -> tuple:
    """Resolve the distributions (:class:`autobal.analysis.studies.montecarlo.Distribution`, name -> one) against the
    model's nominal values; a lognormal with a mean <= 0 is refused naming the parameter."""
    out = []
    for name, d in parameters.items():
        if d.distribution == "uniform" and d.low is not None:
            low, high = d.low, d.high
            mean, std = 0.5 * (low + high), (high - low) / math.sqrt(12.0)
        else:
            mean = d.mean if d.mean is not None else nominal[name]
            std = d.std if d.std is not None else d.cv * abs(mean)
            low, high = mean - math.sqrt(3.0) * std, mean + math.sqrt(3.0) * std
        if d.distribution == "lognormal" and not mean > 0:
            raise ScenarioError(f"{where}.{name}: a lognormal parameter needs a positive mean, got {mean:g}")
        out.append(Marginal(name, d.distribution, float(mean), float(std), float(low), float(high)))
    return tuple(out)


def correlation_matrix(names, correlations) -> np.ndarray:
    """The copula's correlation matrix of the parameters ``names`` from the scene's pairs
    (:class:`autobal.analysis.studies.montecarlo.Correlation`: ``between`` two names, ``rho``); 1 on the diagonal."""
    c = np.eye(len(names))
    for r in correlations:
        i, j = names.index(r.between[0]), names.index(r.between[1])
        c[i, j] = c[j, i] = r.rho
    return c


@dataclass(frozen=True)
class Sampler:
    """Seeded, reproducible samples: chunk i draws from SeedSequence(seed, spawn_key=(stream, i)), so
    a chunk's samples depend only on (seed, stream, chunk index, chunk size), not on who computes it."""

    marginals: tuple
    correlation: np.ndarray | None
    seed: int
    stream: int = 0  # independent streams of one seed: 0 the statics, 1 the AFC

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.marginals]

    def draw(self, chunk: int, n: int) -> np.ndarray:
        rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(self.seed, spawn_key=(self.stream, chunk))))
        z = rng.standard_normal((n, len(self.marginals)))
        if self.correlation is not None:
            z = z @ np.linalg.cholesky(self.correlation).T
        return np.column_stack([m.transform(z[:, j], rng) for j, m in enumerate(self.marginals)])

    def covariance(self) -> np.ndarray:
        """Covariance of the parameters (the copula's correlation taken as theirs)."""
        s = np.array([m.std for m in self.marginals])
        c = self.correlation if self.correlation is not None else np.eye(len(s))
        return c * np.outer(s, s)



def statistics(Y: np.ndarray, band_sigma: float, quantiles) -> dict:
    """Per column of Y (samples x grid): population mean and std over the finite samples (as the
    source's S/N, sqrt(S2/N - (S/N)^2)), cv, bands mean +- k std, quantiles, valid counts."""
    ok = np.isfinite(Y)
    n = ok.sum(axis=0)
    Z = np.where(ok, Y, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = Z.sum(axis=0) / n
        std = np.sqrt(np.where(ok, (Y - mean) ** 2, 0.0).sum(axis=0) / n)
        cv = std / np.abs(mean)
    qs = np.full((len(quantiles), Y.shape[1]), np.nan)
    for j in range(Y.shape[1]):
        if n[j]:
            qs[:, j] = np.quantile(Y[ok[:, j], j], quantiles)
    return {"mean": mean, "std": std, "cv": cv, "band_low": mean - band_sigma * std,
            "band_high": mean + band_sigma * std, "spread": band_sigma * cv,
            "quantiles": {f"{q:g}": qs[i] for i, q in enumerate(quantiles)},
            "valid": n, "invalid": Y.shape[0] - n}



def relative_standard_errors(Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Monte Carlo standard errors, relative, of the mean and of cv = std/mean per column of Y (samples x
    grid, NaN = invalid sample), from the samples themselves: SE(mean) = std/sqrt(n); SE(cv) by the delta
    method, the standard deviation of the influence function (d^2 - s^2)/(2 s m) - s d/m^2, d = y - m,
    over sqrt(n).  A spread k cv has the relative error of cv."""
    ok = np.isfinite(Y)
    n = ok.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        m = np.where(ok, Y, 0.0).sum(axis=0) / n
        d = np.where(ok, Y - m, 0.0)
        s = np.sqrt((d**2).sum(axis=0) / n)
        infl = np.where(ok, (d**2 - s**2) / (2 * s * m) - s * d / m**2, 0.0)
        se_cv = np.sqrt((infl**2).sum(axis=0) / n) / np.sqrt(n)
        return s / np.abs(m) / np.sqrt(n), se_cv / (s / np.abs(m))



@dataclass(frozen=True)
class Chunks:
    """``samples`` draws of ``sampler`` split into chunks of ``chunk_size`` (the last one shorter): the
    unit of work an executor runs; chunk i's samples depend only on the seed and i."""

    sampler: Sampler
    samples: int
    chunk_size: int

    @property
    def chunks(self) -> int:
        """Number of chunks."""
        return -(-self.samples // self.chunk_size)

    def draw(self, chunk: int) -> np.ndarray:
        """The samples of chunk ``chunk`` (rows in the order of the sampler's names)."""
        return self.sampler.draw(chunk, min(self.chunk_size, self.samples - chunk * self.chunk_size))
