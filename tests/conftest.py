"""Shared fixtures: one FE cache directory and one coarse disc reduction per test session, so
the flexible test modules reduce the coarse disc once (a cold reduction is ~15 s in CI)."""

from __future__ import annotations

import pytest

COARSE_DISC = {"maxh_m": 8e-3, "n_modes": 12, "mesh_order": 1, "attach_per_tooth": 0}
"""8 mm linear tets, 6 static + 12 fixed-interface modes: quick, and elastic enough to test with."""


@pytest.fixture(scope="session")
def fe_cache(tmp_path_factory):
    """A private FE cache (``RVFLEX_CACHE_DIR``) for the session: cold, never the user's."""
    cache = tmp_path_factory.mktemp("fe-cache")
    mp = pytest.MonkeyPatch()
    mp.setenv("RVFLEX_CACHE_DIR", str(cache))
    yield cache
    mp.undo()


@pytest.fixture(scope="session")
def coarse_disc(fe_cache):
    """(RV-40E spec, its coarse disc reduction)."""
    from rvflex import catalog
    from rvflex.fe.reduce import reduce_part

    spec = catalog.load("rv40e")
    return spec, reduce_part(spec, "disc", **COARSE_DISC)


@pytest.fixture(scope="module")
def loaded():
    """(contact, pose): a single RV-40E disc turned 3″ into its pins (about 10 pins loaded) with a linear
    law — the state the flexible-disc and flexible-housing contact tests perturb. One per module: the
    contact keeps its closest-point warm start, which a module's evaluations move."""
    import numpy as np

    from rvflex import catalog
    from rvflex.contact.cycloid_pin import ContactLaw
    from rvflex.contact.single_disc import build_single_disc
    from rvflex.geometry.clearance import initial_clearance_numeric
    from rvflex.geometry.pins import nominal_disc_pose

    stage = catalog.load("rv40e").cycloid
    contact = build_single_disc(stage, ContactLaw.linear(2e8)).contact
    centre, angle = nominal_disc_pose(stage, 0.3)
    closing = initial_clearance_numeric(stage, eccentric_angle_rad=0.3).turn_neg_rad
    return contact, np.array([centre[0], centre[1], angle + closing - 1.5e-5])


@pytest.fixture()
def netgen_fails(monkeypatch):
    """netgen failing to mesh any part (its OCC geometry's GenerateMesh raises "netgen: surface meshing
    failed"), in this process: a deliberately failing FE build."""
    import netgen.occ

    class Broken:
        def __init__(self, shape):
            pass

        def GenerateMesh(self, **kw):
            raise RuntimeError("netgen: surface meshing failed")

    monkeypatch.setattr(netgen.occ, "OCCGeometry", Broken)
