"""Exact cycloid-stage geometry: profiles, pins, closest-point gaps and the papers' closed forms."""

from rvflex.geometry.profile import CycloidProfile, GapResult, build_profile, check_stage

__all__ = ["CycloidProfile", "GapResult", "build_profile", "check_stage"]
