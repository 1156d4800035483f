"""The spatial fidelity's inputs: the cranks' axial layout in the spec (TOML round trip, bad values refused in one
line naming the field, the built-in units' assumed values), ``ReducerSpec.check_spatial``, and the options
(``SpatialSettings``, the ``"spatial"`` preset, its table form); ``build_reducer`` builds the beam cranks they ask
for."""

from __future__ import annotations

import dataclasses
import re

import pytest

from rvflex import catalog
from rvflex.options import ModelOptions, SpatialSettings, as_options
from rvflex.spec import SpecError, dumps_spec, loads_spec
from rvflex.tilt import MOMENT_SLICES

SPAN = {"rv40e": 0.033, "rv80e": 0.039, "rv160n": 0.051}  # m, the plan's table (docs: catalogue comments)


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


def _one_line(err: pytest.ExceptionInfo) -> str:
    msg = str(err.value)
    assert "\n" not in msg, msg
    return msg


# ------------------------------------------------------------------------------ spec fields


@pytest.mark.parametrize("name", catalog.names())
def test_built_in_units_place_their_cranks_in_space(name):
    spec = catalog.load(name)
    cr = spec.cranks
    assert cr.support_span_m == SPAN[name]
    # the supports sit in the end plates at mid-thickness, as the main pair's rows do (the stated assumption)
    assert cr.support_span_m == spec.bearings.main_pair.row_spacing_m
    # the discs lie between the supports, and the planet gear outboard of the input-end plate
    assert max(abs(z) for z in cr.eccentric_axial_positions_m) + spec.cycloid.disc_thickness_m / 2 \
        < cr.support_span_m / 2
    assert cr.gear_axial_position_m + spec.input_stage.face_width_m / 2 \
        < -(cr.support_span_m / 2 + spec.carrier.plate_thickness_m / 2)
    # a support journal is the eccentric journal less a shoulder: thinner, and still a shaft of some mm
    assert 0.005 < cr.support_journal_radius_m < cr.eccentric_journal_radius_m
    spec.check_spatial()  # every built-in unit has what the spatial model needs


@pytest.mark.parametrize("name", catalog.names())
def test_each_new_field_has_its_source_or_is_an_assumption_with_its_reasoning(name):
    text = catalog.text(name)
    lines = text.splitlines()
    pair = lines[lines.index("[bearings.crank_support_pair]") + 1:]
    pair = [s for s in pair[:next(i for i, s in enumerate(pair) if not s.strip())]]
    assert len(pair) == 8, pair
    crank = [next(s for s in lines if s.startswith(f"{key} =")) for key in ("support_span_m", "support_journal_radius_m",
                                                                             "gear_axial_position_m")]
    for line in crank + pair:
        assert re.search(r"#\s*(assumed: \S.{20,}|seed 00\d (Table \d|§[\d.]+) \(.{10,})", line), line


def test_spec_with_and_without_the_crank_layout_round_trips(rv40e):
    text = dumps_spec(rv40e)
    assert "support_span_m = 0.033" in text and "gear_axial_position_m = -0.0295" in text
    assert loads_spec(text) == rv40e
    bare = dataclasses.replace(rv40e, cranks=dataclasses.replace(
        rv40e.cranks, support_span_m=None, support_journal_radius_m=None, gear_axial_position_m=None))
    bare_text = dumps_spec(bare)
    assert "support_span_m" not in bare_text and "gear_axial_position_m" not in bare_text
    again = loads_spec(bare_text, "user.toml")
    assert again == bare and again.cranks.support_span_m is None
    assert dumps_spec(again) == bare_text


@pytest.mark.parametrize(("key", "value", "rule"), [
    ("support_span_m", "-0.033", "expected a positive length in metres"),
    ("support_span_m", "0.0", "expected a positive length in metres"),
    ("support_span_m", "33.0", "expected a positive length in metres, 1 mm to 1 m"),  # millimetres, not metres
    # the eccentrics at ±5.5 mm do not fit between supports 10 mm apart
    ("support_span_m", "0.010", "must exceed twice the outermost eccentric's axial position (0.011 m)"),
    ("support_span_m", '"33 mm"', "must be a number"),
    ("support_journal_radius_m", "-0.008", "expected a positive length in metres"),
    ("support_journal_radius_m", "8.0", "expected a positive length in metres, 1 mm to 200 mm"),
    ("gear_axial_position_m", "-29.5", "expected metres within ±0.5 m"),
])
def test_bad_crank_layout_is_refused_in_one_line_naming_the_field(rv40e, key, value, rule):
    text = re.sub(rf"(?m)^{key} = \S+", f"{key} = {value}", dumps_spec(rv40e))
    with pytest.raises(SpecError) as info:
        loads_spec(text, "user.toml")
    msg = _one_line(info)
    assert info.value.field == f"cranks.{key}" and msg.startswith(f"user.toml: cranks.{key} = "), msg
    assert rule in msg, msg


# ------------------------------------------------------------------------------ check_spatial


def test_check_spatial_names_what_is_missing(rv40e):
    no_pair = dataclasses.replace(rv40e, bearings=dataclasses.replace(rv40e.bearings, main_pair=None))
    with pytest.raises(SpecError) as info:
        no_pair.check_spatial()
    msg = _one_line(info)
    assert info.value.field == "bearings.main_pair" and "which --spatial needs" in msg, msg
    no_span = dataclasses.replace(rv40e, cranks=dataclasses.replace(rv40e.cranks, support_span_m=None))
    with pytest.raises(SpecError) as info:
        no_span.check_spatial("options.spatial")
    msg = _one_line(info)
    assert info.value.field == "cranks.support_span_m" and "which options.spatial needs" in msg, msg
    # the pair comes first: a spec lacking both is told about the pair
    both = dataclasses.replace(no_pair, cranks=no_span.cranks)
    with pytest.raises(SpecError, match=r"^bearings\.main_pair = None"):
        both.check_spatial()


# ------------------------------------------------------------------------------ options


def test_spatial_preset_is_rigid_with_the_moment_slices():
    opts = ModelOptions.preset("spatial")
    assert opts == ModelOptions.spatial_rigid() == as_options("spatial")
    assert opts.spatial == SpatialSettings() and opts.face_slices == MOMENT_SLICES
    assert not (opts.flexible_discs_on or opts.flexible_carrier_on or opts.flexible_housing_on)
    assert opts.fidelity == "spatial" and ModelOptions.rigid().fidelity == "rigid"
    assert opts.describe().endswith("; spatial: rigid cranks, pins bending where seated")
    assert opts.as_dict()["spatial"] == {"crank": "rigid", "crank_elements": 1, "pin_bending": True}
    # a planar model's record is what it was (stored sweeps hash it)
    assert "spatial" not in ModelOptions.rigid().as_dict()
    beam = ModelOptions.spatial_rigid(8, SpatialSettings(crank="beam", crank_elements=4))
    assert beam.face_slices == 8 and "beam cranks (4 elements/segment)" in beam.describe()


@pytest.mark.parametrize(("make", "field", "rule"), [
    (lambda: SpatialSettings(crank="flexible"), "crank", "must be one of 'rigid', 'beam'"),
    (lambda: SpatialSettings(crank_elements=0), "crank_elements", "must be an integer from 1 to 64"),
    (lambda: SpatialSettings(crank_elements=True), "crank_elements", "must be an integer from 1 to 64"),
    (lambda: SpatialSettings(pin_bending="yes"), "pin_bending", "must be true or false"),
    (lambda: ModelOptions(spatial="rigid"), "spatial", "must be None or an rvflex.options.SpatialSettings"),
    (lambda: ModelOptions.spatial_rigid(1), "face_slices", "must be at least 2 with spatial"),
    (lambda: dataclasses.replace(ModelOptions.flexible_discs(), face_slices=4, spatial=SpatialSettings()),
     "spatial", "needs rigid parts, got FE discs: FE bodies free out of their plane are not modelled"),
    (lambda: dataclasses.replace(ModelOptions.flexible_all(), face_slices=4, spatial=SpatialSettings()),
     "spatial", "got FE discs, carrier, housing"),
])
def test_bad_spatial_options_are_one_line_naming_the_option(make, field, rule):
    with pytest.raises(SpecError) as info:
        make()
    msg = _one_line(info)
    assert info.value.field == field and rule in msg, msg


def test_spatial_options_from_a_model_table():
    opts = ModelOptions.from_table({"fidelity": "spatial", "face_slices": 6,
                                    "spatial": {"crank": "beam", "crank_elements": 4, "pin_bending": False}})
    assert opts == ModelOptions.spatial_rigid(6, SpatialSettings("beam", 4, False))
    for table, field, rule in [
        ({"spatial": {"crank": "beam"}}, "[model].spatial", "the model is planar with fidelity = 'rigid'"),
        ({"fidelity": "spatial", "spatial": {"elements": 4}}, "[model].spatial.elements", "unknown key; valid: crank"),
        ({"fidelity": "spatial", "spatial": {"crank_elements": 0}}, "[model].spatial.crank_elements", "from 1 to 64"),
        ({"fidelity": "spatial", "spatial": 4}, "[model].spatial", "must be a table of SpatialSettings fields"),
        ({"fidelity": "spatial", "face_slices": 1}, "[model].face_slices", "at least 2 with spatial"),
        ({"fidelity": "spatial", "discs": {"n_modes": 8}}, "[model].discs", "rigid with fidelity = 'spatial'"),
    ]:
        with pytest.raises(SpecError) as info:
            ModelOptions.from_table(table, source="d.toml")
        msg = _one_line(info)
        assert info.value.field == field and rule in msg and msg.startswith("d.toml: "), msg


def test_build_reducer_builds_the_beam_cranks_the_options_ask_for(rv40e):
    """``crank="beam"`` with ``crank_elements`` reaches the part builder: each crank one station chain of that
    many elements per segment (the beam itself: tests/test_spatial_beam.py); rigid cranks have none."""
    from rvflex.model import build_reducer

    beam = build_reducer(rv40e, options=ModelOptions.spatial_rigid(4, SpatialSettings(crank="beam", crank_elements=3)))
    assert beam.cranks.beam.elements == 3 and [len(s) for s in beam.cranks.stations] == [19, 19]
    rigid = build_reducer(rv40e, options=ModelOptions.spatial_rigid(4))
    assert rigid.cranks.beam is None and rigid.cranks.stations == ()


def test_the_unit_matrix_offers_the_spatial_fidelity_and_names_the_choices():
    from rvflex.scenarios.unit_matrix import options_for

    assert options_for("spatial") == ModelOptions.spatial_rigid()
    with pytest.raises(SpecError, match=r"^fidelity = 'spatail': must be one of 'rigid', 'flexible', "
                                        r"'flexible-carrier', 'flexible-all', 'spatial'.*did you mean 'spatial'"):
        options_for("spatail")
