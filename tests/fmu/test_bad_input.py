"""Bad input, tried systematically with hypothesis on every FMU: NaN, inf, negative and huge parameters and
inputs, zero, negative and non-finite step sizes. Every case ends in an error status with a log message naming
the variable and its allowed range, or in finite outputs; never a crash of the host, never a silent NaN output.

The number of cases tried is counted and checked at the end (CASES)."""

import math

import pytest
from fmpy.fmi1 import FMICallException
from fmu_helpers import INPUTS, inputs_of, open_instance, outputs_of
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from ujfmu.build import FMUS, fmu_class

EXAMPLES = 150
CASES = {"parameter": 0, "input": 0, "step": 0}
BAD = st.one_of(st.sampled_from([math.nan, math.inf, -math.inf, 1e300, -1e300, -1.0, 0.0, 1e-300, -1e-300]),
                st.floats(allow_nan=True, allow_infinity=True, width=64))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def real_parameters(name):
    return [v for v in fmu_class(name).VARIABLES if v.causality == "parameter" and v.type is float]


def step_some(inst, log, n=5, h=1e-3):
    """n steps with good inputs: each is refused with a logged message, or leaves every output finite."""
    outputs = outputs_of(inst)
    for k in range(n):
        t = k * h
        inst.set(**{name: INPUTS[name](t) for name in inputs_of(inst)})
        status = inst.raw("fmi2DoStep")(inst.slave.component, t, h, 1)
        if status != 0:
            assert status == 2 and "refused" in log[-1], (status, log[-3:])
            return
        values = inst.get(*outputs)
        bad = [o for o, v in zip(outputs, values) if not math.isfinite(v)]
        assert not bad, f"silent non-finite outputs {bad}"


def named_with_range(message, variable):
    return variable in message and ("allowed range" in message or "allowed" in message)


@pytest.mark.parametrize("name", list(FMUS))
def test_bad_parameters(fmu_dir, name):
    params = real_parameters(name)

    @SETTINGS
    @given(var=st.sampled_from(params), value=BAD)
    def case(var, value):
        CASES["parameter"] += 1
        log = []
        inst = open_instance(fmu_dir, name, log)
        try:
            try:
                inst.initialize({var.name: value})
            except FMICallException:
                assert any(named_with_range(m, var.name) for m in log), (var.name, value, log)
                return
            step_some(inst, log)      # accepted: then it must behave
        finally:
            inst.free()

    case()


#: hand-picked boundaries hypothesis rarely hits (an exclusive minimum exactly, a joint angle of 90 deg)
BOUNDARY_PARAMETERS = [
    ("CardanJoint", "J1", -1e-6), ("CardanJoint", "J2", -1.0), ("CardanJoint", "bend_angle", math.radians(90)),
    ("CardanJoint", "bend_angle", math.radians(120)), ("CardanJoint", "error_angle_beta", math.nan),
    ("CardanJoint", "bend_plane_angle", math.inf),
    ("DoubleCardanDriveline", "beta1", math.radians(90.0)), ("DoubleCardanDriveline", "beta2", -math.radians(95.0)),
    ("DoubleCardanDriveline", "k_theta", 0.0), ("DoubleCardanDriveline", "k_phi", -1.0),
    ("DoubleCardanDriveline", "m_s", 0.0), ("DoubleCardanDriveline", "J_load", -1.0),
    ("DoubleCardanDriveline", "I_cross_pin", -1e-3), ("DoubleCardanDriveline", "L_c", math.nan),
    ("DoubleCardanDriveline", "xi_theta", math.inf),
    ("TwinJeffcottRotor", "beta", math.radians(90.0)), ("TwinJeffcottRotor", "M1", 0.0),
    ("TwinJeffcottRotor", "J_M2", -1.0), ("TwinJeffcottRotor", "K1X", math.nan), ("TwinJeffcottRotor", "C2T", -0.1),
    ("TwinJeffcottRotor", "L1", 0.0), ("TwinJeffcottRotor", "e", math.inf), ("TwinJeffcottRotor", "m_u2", -1e-3),
    ("TwinJeffcottRotor", "K2T", 0.0),
    ("RingCoupling", "d", 0.0), ("RingCoupling", "d", -1e-3), ("RingCoupling", "I2", 0.0), ("RingCoupling", "R", 0.0),
    ("RingCoupling", "R", -0.1), ("RingCoupling", "e", math.nan), ("RingCoupling", "E", math.nan),
    ("RingCoupling", "c_s", -1.0),
    ("Load", "omega_smooth", 0.0), ("Load", "omega_smooth", -1e-12), ("Load", "omega_smooth", math.nan),
]


@pytest.mark.parametrize("name, param, value", BOUNDARY_PARAMETERS)
def test_boundary_parameters_are_errors_naming_them(fmu_dir, name, param, value):
    log = []
    inst = open_instance(fmu_dir, name, log)
    try:
        with pytest.raises(FMICallException, match="fmi2ExitInitializationMode"):
            inst.initialize({param: value})
    finally:
        inst.free()
    assert any(param in m and "allowed range" in m for m in log), log


@pytest.mark.parametrize("name, values, words, absent", [
    ("DoubleCardanDriveline", {"beta1": 12.0},
     "invalid parameters: beta1 = 12.0 is outside its allowed range [-1.553343034, 1.553343034] rad (12 deg = "
     "0.2094 rad?)", "invalid inputs"),
    ("CardanJoint", {"tau_load": math.nan}, "invalid inputs: tau_load = nan is not a finite number",
     "invalid parameters"),
    ("Motor", {"omega_set": 15000.0},
     "invalid parameters: omega_set = 15000.0 is outside its allowed range [-10000, 10000] rad/s (15000 rpm = "
     "1571 rad/s?)", "invalid inputs"),
])
def test_initialization_errors_name_inputs_as_inputs_and_hint_at_unit_slips(fmu_dir, name, values, words, absent):
    """A value out of range that would be in range read as deg (rad variables) or rpm (rad/s variables) gets the
    converted value as a hint; an input is named as an input, not as a parameter."""
    log = []
    inst = open_instance(fmu_dir, name, log)
    try:
        with pytest.raises(FMICallException, match="fmi2ExitInitializationMode"):
            inst.initialize(values)
    finally:
        inst.free()
    assert any(words in m for m in log), log
    assert not any(absent in m for m in log), log


def test_unit_hints_only_where_the_converted_value_fits():
    from ujfmu.fmu.base import input_, parameter
    angle = parameter("beta1", 0.1, "rad", "an angle", min=-1.5, max=1.5)
    assert angle.check(12.0).endswith("(12 deg = 0.2094 rad?)")
    assert "deg" not in angle.check(120.0) and "rpm" not in angle.check(120.0)   # 2.09 rad: out of range too
    assert angle.check(math.pi / 2).endswith("rad")   # just past the bound: a value in rad, not a slip
    speed = input_("omega_in", 0.0, "rad/s", "a speed", min=-1e4, max=1e4)
    assert speed.check(-20000.0).endswith("(-20000 rpm = -2094 rad/s?)")
    torque = input_("tau_load", 0.0, "N.m", "a torque", min=-1e7, max=1e7)
    assert torque.check(2e7).endswith("N.m")


def test_an_input_out_of_range_while_stepping_names_an_unstable_coupling_first(fmu_dir):
    """A speed of -36086 rad/s arriving at a step (a host's explicit coupling diverging, as libcosim's did): the
    refusal names that cause and its remedies before the unit slip it might also be; a NaN is only not finite. At
    the first step no coupling can have diverged yet: an input past its range there (a host's table in rpm) names
    the slip it likely is, not an unstable coupling."""
    log = []
    inst = open_instance(fmu_dir, "DoubleCardanDriveline", log)
    try:
        inst.initialize()
        inst.set(omega_in=15000.0, tau_load=0.0)
        assert inst.raw("fmi2DoStep")(inst.slave.component, 0.0, 1e-3, 1) == 2
        assert "omega_in = 15000.0 is outside its allowed range [-10000, 10000] rad/s (15000 rpm = 1571 rad/s?)" \
            in log[-1] and "coupling" not in log[-1], log
        inst.set(omega_in=10.0)
        assert inst.raw("fmi2DoStep")(inst.slave.component, 0.0, 1e-3, 1) == 0
        inst.set(omega_in=-36085.6)
        assert inst.raw("fmi2DoStep")(inst.slave.component, 1e-3, 1e-3, 1) == 2
        assert "omega_in = -36085.6 is outside its allowed range [-10000, 10000] rad/s" in log[-1], log
        assert "coupling going unstable" in log[-1] and "torque-driven wiring" in log[-1], log
        assert log[-1].index("coupling going unstable") < log[-1].index(
            "or, if the host gives this input in another unit: -36085.6 rpm = -3779 rad/s?"), log
        inst.set(omega_in=math.nan)
        assert inst.raw("fmi2DoStep")(inst.slave.component, 1e-3, 1e-3, 1) == 2
        assert "not a finite number" in log[-1] and "coupling" not in log[-1], log
    finally:
        inst.free()


@pytest.mark.parametrize("name", list(FMUS))
def test_bad_inputs(fmu_dir, name):
    @SETTINGS
    @given(index=st.integers(min_value=0, max_value=7), value=BAD)
    @example(index=0, value=math.nan)     # always tried: a NaN on each port, then recovery
    @example(index=1, value=math.nan)
    def case(index, value):
        CASES["input"] += 1
        log = []
        inst = open_instance(fmu_dir, name, log)
        try:
            inst.initialize()
            names = inputs_of(inst)
            target = names[index % len(names)]
            inst.set(**{n: INPUTS[n](0.0) for n in names})
            inst.set(**{target: value})
            status = inst.raw("fmi2DoStep")(inst.slave.component, 0.0, 1e-3, 1)
            if status != 0:   # an input out of its range, or one in range that moves the model out of its validity
                assert status == 2 and (named_with_range(log[-1], target) or "left the model's validity" in log[-1]), \
                    (target, value, log[-2:])
                step_some(inst, log)  # the instance stays usable once the input is good again
            else:
                assert all(math.isfinite(v) for v in inst.get(*outputs_of(inst))), (target, value)
        finally:
            inst.free()

    case()


@pytest.mark.parametrize("name", list(FMUS))
def test_bad_step_sizes(fmu_dir, name):
    @SETTINGS
    @given(h=st.one_of(st.sampled_from([0.0, -1e-3, -0.0, math.nan, math.inf, -math.inf]),
                       st.floats(max_value=0.0)))
    def case(h):
        CASES["step"] += 1
        log = []
        inst = open_instance(fmu_dir, name, log)
        try:
            inst.initialize()
            inst.set(**{n: INPUTS[n](0.0) for n in inputs_of(inst)})
            assert inst.raw("fmi2DoStep")(inst.slave.component, 0.0, h, 1) == 2
            assert "step size" in log[-1] and "finite and > 0" in log[-1]
        finally:
            inst.free()

    case()


def test_case_count():
    """Runs last in this file: how many bad-input cases the tests above tried (at least EXAMPLES each)."""
    n = len(FMUS)
    print(f"bad-input cases tried: {CASES}")
    assert CASES["parameter"] >= n * EXAMPLES // 2 and CASES["input"] >= n * EXAMPLES // 2
    assert CASES["step"] >= n * 6


def test_non_finite_values_are_refused_even_without_a_declared_range():
    """The range check alone would let NaN through (comparisons with NaN are false) and, for a variable declared
    without bounds, infinities too: Var.check refuses every non-finite value by itself."""
    from ujfmu.fmu.base import input_, parameter
    for var in (parameter("x", 0.0, "1", "a parameter without bounds"), input_("u", 0.0, "N.m", "an input")):
        for value in (math.nan, math.inf, -math.inf):
            assert f"{var.name} = {value!r} is not a finite number" in var.check(value)
        assert var.check(1e300) is None and var.check(-1e-300) is None


def refused_first_step(fmu_dir, name: str, parameters: dict) -> str:
    """The message of the FMU's refusal of its first 1 ms step at these parameters, its inputs at rest."""
    log = []
    inst = open_instance(fmu_dir, name, log)
    try:
        inst.initialize(parameters)
        inst.set(**{n: INPUTS[n](0.0) for n in inputs_of(inst)})
        assert inst.raw("fmi2DoStep")(inst.slave.component, 0.0, 1e-3, 1) != 0
    finally:
        inst.free()
    return log[-1]


def test_a_stiffness_beyond_any_step_is_refused_naming_its_rate_and_the_parameters(fmu_dir):
    """k_theta = 1e9 N.m/rad and xi_theta = 0.01 s are inside the declared ranges, but the joints' modulation of
    that shaft's damping (c_theta r^2, r^2 within [cos^2 b, 1/cos^2 b]), which the exponential Adams method takes
    explicitly, has a rate of about 1.6e8 1/s: a 1 ms step would take about 3.2e5 substeps. The step is refused
    with the rate, the count and the parameters to check; a smaller step is said not to help in all. (The shaft's
    own modes, however stiff, set no substep: the method takes them exactly.)"""
    message = refused_first_step(fmu_dir, "DoubleCardanDriveline", {"k_theta": 1e9, "xi_theta": 0.01})
    assert "refused" in message and "fastest rate 1.6" in message and "3.23e+05 substeps" in message, message
    assert "stiffness, damping and inertia" in message and "not fewer in all" in message
    assert "RK4" not in message   # the double Cardan steps with an exponential Adams method: the count is its rule's
    # the model's parts' rates follow, the fastest first, each with the parameters that set it
    assert ("; the parameters to check, by the bound of the natural rate of each part of the model at these "
            "parameters, the fastest first: "
            "the intermediate shaft's torsion (k_theta = 1e+09 N.m/rad, xi_theta = 0.01 s, J_load = 0.0045 kg.m2) "
            "2.38e+09 1/s, the lateral support") in message, message
    # a support meant rigid (a trial's k_phi = 1e12 N/m at Omar's xi_phi): its motion is named first
    message = refused_first_step(fmu_dir, "DoubleCardanDriveline", {"k_phi": 1e12})
    assert "the fastest first: the lateral support (k_phi = 1e+12 N/m, xi_phi = 0.002 s, m_s = 4.09 kg) " \
        "4.89e+08 1/s, the intermediate shaft's torsion" in message, message


@pytest.mark.parametrize("name", ["TwinJeffcottRotor", "TwinJeffcottRotorTorqueDriven"])
def test_a_twin_rotor_step_refused_for_its_substeps_names_the_disc_that_sets_the_rate(fmu_dir, name):
    """C1X = 1e9 N.s/m (the declared maximum) damps disc 1's lateral motion at about 3e8 1/s: a 1 ms step is refused,
    and the message names disc 1's lateral motion, with its parameters, as the fastest of the rotor's parts."""
    assert ("the fastest first: disc 1's lateral motion (K1X = 82081.5, K1Y = 82081.5 N/m, C1X = 1e+09, "
            "C1Y = ") in refused_first_step(fmu_dir, name, {"C1X": 1e9})
