"""Options that select behaviour: Literal types, one check (rvflex.choices.check_choice) that
refuses any other value naming the field and listing the allowed ones, wherever the option enters."""

from __future__ import annotations

import pytest

from rvflex.choices import SeatCoupling, check_choice, choices
from rvflex.spec import SpecError


def test_check_choice_names_the_field_and_lists_the_values():
    check_choice("seat_coupling", "rbe2", SeatCoupling)
    with pytest.raises(SpecError, match=r"^f\.toml: seat_coupling = 'RBE2': must be one of 'rbe3', 'rbe2'; "
                                        r"did you mean 'rbe2'\?$"):
        check_choice("seat_coupling", "RBE2", SeatCoupling, "f.toml")
    with pytest.raises(SpecError, match=r"^seat_coupling = 'spring': must be one of 'rbe3', 'rbe2'$"):
        check_choice("seat_coupling", "spring", SeatCoupling)  # close to nothing: no suggestion
    with pytest.raises(SpecError, match=r"seat_coupling = None: must be one of 'rbe3', 'rbe2'$"):
        check_choice("seat_coupling", None, SeatCoupling)
    assert choices(SeatCoupling) == ("rbe3", "rbe2")


def test_each_option_is_checked_where_it_enters():
    from rvflex.contact.cycloid_pin import ContactLaw
    from rvflex.fe.reduce import PartSettings, reduce_part
    from rvflex.options import ModelOptions

    cases = [
        (lambda: ContactLaw("hertz", stiffness=1e9), r"contact law kind = 'hertz': must be one of 'linear', 'power'"),
        (lambda: PartSettings(6e-3, 10, patch_shape="box"), r"patch_shape = 'box': must be one of 'hat', 'cos2'"),
        (lambda: PartSettings(6e-3, 10, seat_coupling="rbe4"), r"seat_coupling = 'rbe4': must be one of 'rbe3'"),
        (lambda: reduce_part(None, "case"), r"part = 'case': must be one of 'disc', 'carrier', 'housing'"),
        (lambda: ModelOptions(carrier_seat_marker="nodes"), r"carrier_seat_marker = 'nodes': must be one of 'virtual'"),
        (lambda: ModelOptions.preset("elastic"), r"fidelity = 'elastic': must be one of 'rigid', 'flexible', "
                                                 r"'flexible-carrier', 'flexible-all'"),
    ]
    for make, message in cases:
        with pytest.raises(SpecError, match=message):
            make()


def test_scenario_and_sweep_options_are_checked():
    import rvflex
    from rvflex.sweeps import Design, Factor, sweep

    spec = rvflex.load_reducer("rv40e")
    with pytest.raises(SpecError, match=r"^mode = 'static': must be one of 'quasi-static', 'dynamic'"):
        rvflex.LoadedTE(spec, mode="static")
    design = Design("d", "rv40e", "te", "single-factor", (Factor("eccentricity", (1e-6,)),), 412.0)
    with pytest.raises(SpecError, match=r"^executor = 'threads': must be one of 'serial', 'process', 'dask'"):
        sweep(design, "unused.sqlite", executor="threads")
    with pytest.raises(SpecError, match=r"^kind = 'L8': must be one of"):
        Design("d", "rv40e", "te", "L8", (), 412.0)
    with pytest.raises(SpecError, match=r"^distribution = 'gauss': must be one of 'uniform', 'normal'"):
        Design("d", "rv40e", "te", "monte-carlo", (), 412.0, distribution="gauss")


def test_part_builders_refuse_an_unknown_fidelity_before_building():
    from rvflex.parts import carrier, crankshaft, cycloid_disc, input_stage, pin_ring

    for build, args in [(carrier.build, (None,) * 5), (crankshaft.build, (None,) * 6),
                        (cycloid_disc.build, (None,) * 7), (input_stage.build, (None,) * 3),
                        (pin_ring.build, (None,) * 3)]:
        with pytest.raises(SpecError, match=r"fidelity = 'elastic': must be one of 'rigid', 'flexible'"):
            build(*args, fidelity="elastic")
    for build, args in [(crankshaft.build, (None,) * 6), (input_stage.build, (None,) * 3)]:
        with pytest.raises(NotImplementedError, match=r"fidelity = 'flexible'"):
            build(*args, fidelity="flexible")  # rigid in every model: refused, not silently rigid
    with pytest.raises(ValueError, match=r"fidelity = 'flexible': the housing needs its reduction"):
        pin_ring.build(None, None, None, fidelity="flexible")  # flexible only on its FE reduction
