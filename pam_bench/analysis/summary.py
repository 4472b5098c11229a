"""What an extraction finds, as its summary.json holds it: typed records (``extract``)."""

from __future__ import annotations

from typing import Any, TypedDict

from pam_bench.analysis.static import GainSummary

__all__ = ['Summary', 'StepSummary']


class StepSummary(TypedDict):
    """The step responses' fits (one dict per record: 004 Eq. 4's b, c, d, F_a0 at its x)
    and each coefficient's polynomial over the contraction (``coefficient_polynomials``)."""

    fits: list[dict[str, Any]]
    polynomials: dict[str, Any]


class Summary(GainSummary, total=False):
    """What ``extract`` finds, as summary.json holds it: a key per protocol kind the bags
    hold (``analysis.static.gain_summary``), the step fits, the force models compared, where
    the time went, the bags and how each was made, the files written."""

    step_response: StepSummary
    model_comparison: list[dict[str, Any]]
    model_comparison_by_branch: list[dict[str, Any]]
    model_comparison_length_m: float
    timing_s: dict[str, float]
    bags: list[str]
    runs: list[dict[str, Any] | None]
    inverse_model: str
    figures: list[str]
