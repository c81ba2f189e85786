"""Serialized FMU states carry data only: fmi2DeSerializeFMUstate, called through fmpy as a host does, rejects a
pickle payload, random bytes, truncated and bit-flipped blobs, blobs of the other FMUs and of another build, and
forged blobs (valid checksum) with a wrong field set, wrong types, non-finite values or parameters out of range.
A rejection is fmi2Fatal (pythonfmu 0.7.0 has no path to fmi2Error) with a log message saying why; the instance is
left bitwise unchanged (its re-serialized state is the same bytes) and usable (it then steps bitwise like an
untouched twin). A blob that is accepted restores exactly the state it holds.

The models' STATE and DERIVED declarations cover every attribute they set (Python level, below).

The number of hypothesis cases tried is counted and checked at the end (CASES)."""

import dataclasses
import math
import pickle

import pytest
from fmpy.fmi1 import FMICallException
from fmu_helpers import INPUTS, inputs_of, open_instance, outputs_of
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ujfmu.build import FMUS, fmu_class
from ujfmu.fmu import base

FATAL = 4
H = 1e-3
EXAMPLES = 300
CASES = {"bytes": 0, "forged": 0, "accepted": 0}
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def steps(inst, k0, n):
    """n steps from communication point k0 with the shared input histories; the outputs after every step."""
    names, inputs, rows = outputs_of(inst), inputs_of(inst), []
    for k in range(k0, k0 + n):
        inst.set(**{name: INPUTS[name](k * H) for name in inputs})
        assert inst.raw("fmi2DoStep")(inst.slave.component, k * H, H, 1) == 0
        rows.append(tuple(inst.get(*names)))
    return rows


def serialized(inst):
    state = inst.slave.getFMUstate()
    try:
        return inst.slave.serializeFMUstate(state)
    finally:
        inst.slave.freeFMUstate(state)


def started(fmu_dir, name, instance_name, n=20):
    log = []
    inst = open_instance(fmu_dir, name, log, instance_name)
    inst.initialize()
    steps(inst, 0, n)
    return inst, log


@pytest.fixture(scope="module")
def blobs(fmu_dir):
    """A valid serialized state of every FMU, 20 steps into a run."""
    out = {}
    for name in FMUS:
        inst, _ = started(fmu_dir, name, "source")
        out[name] = serialized(inst)
        inst.free()
    return out


@pytest.fixture
def pair(fmu_dir):
    """pair(name) -> (instance, its log, untouched twin), both 20 steps into the same run; freed afterwards."""
    opened = []

    def _pair(name):
        inst, log = started(fmu_dir, name, "target")
        twin, _ = started(fmu_dir, name, "twin")
        opened.extend((inst, twin))
        return inst, log, twin

    yield _pair
    for inst in opened:
        inst.free()


def restore(inst, log, blob):
    """fmi2DeSerializeFMUstate + fmi2SetFMUstate through fmpy: None when restored, else the rejection's log."""
    before = len(log)
    try:
        state = inst.slave.deSerializeFMUstate(blob)
    except FMICallException as exc:
        assert exc.status == FATAL, exc
        return "\n".join(log[before:])
    inst.slave.setFMUstate(state)
    inst.slave.freeFMUstate(state)
    return None


def check_rejected(inst, log, blob, reason):
    """blob is rejected with reason in the log and the instance is bitwise unchanged."""
    snapshot = serialized(inst)
    message = restore(inst, log, blob)
    assert message is not None, "accepted"
    assert "FMU state rejected" in message and reason in message, message
    assert serialized(inst) == snapshot


def check_outcome(inst, log, blob, snapshot):
    """Either rejection with a reason and the instance unchanged, or a restore of exactly what blob holds (its
    canonical re-encoding), from which the model steps or refuses the step; then back to the snapshot."""
    message = restore(inst, log, blob)
    if message is not None:
        assert "FMU state rejected" in message, message
        assert serialized(inst) == snapshot
        return
    CASES["accepted"] += 1
    cls = fmu_class(inst.md.modelName)
    assert serialized(inst) == base.encode_state(base.decode_state(cls, blob))
    inst.set(**{name: INPUTS[name](0.02) for name in inputs_of(inst)})
    assert inst.raw("fmi2DoStep")(inst.slave.component, 0.02, H, 1) in (0, 2)
    assert restore(inst, log, snapshot) is None


def forge(name, blob, change, build=None):
    """blob of FMU name with its fields changed by change(fields) and a valid checksum (optionally another
    build digest)."""
    cls = fmu_class(name)
    state = base.decode_state(cls, blob)
    fields = dict(state.fields)
    change(fields)
    saved = dict(base._BUILD)
    if build:
        base._BUILD[base.model_stem(cls.__module__)] = build
    try:
        return base.encode_state(base.FmuState(cls, fields))
    finally:
        base._BUILD.clear()
        base._BUILD.update(saved)


class Payload:
    """The classic pickle exploit: unpickling it calls open(path, "w")."""

    def __init__(self, path):
        self.path = path

    def __reduce__(self):
        return open, (self.path, "w")


@pytest.mark.parametrize("name", list(FMUS))
def test_pickle_payload_is_rejected_and_leaves_no_trace(pair, name, tmp_path):
    inst, log, twin = pair(name)
    target = tmp_path / "pwned"
    canary = tmp_path / "canary"
    pickle.loads(pickle.dumps(Payload(str(canary)))).close()
    assert canary.exists()                                  # the payload is live: unpickling it writes a file
    payload = pickle.dumps(Payload(str(target)))
    check_rejected(inst, log, payload, "wrong magic")
    assert not target.exists()
    assert steps(inst, 20, 30) == steps(twin, 20, 30)      # usable, bitwise like the untouched twin


def _set(key, value):
    return lambda f: f.__setitem__(key, value)


#: (what, blob maker (name, its valid blob, every FMU's valid blob) -> blob, the reason the log names)
REJECTED = [
    ("empty", lambda n, v, all_: b"", "truncated"),
    ("truncated header", lambda n, v, all_: v[:20], "truncated"),
    ("truncated fields", lambda n, v, all_: v[:-40], "truncated"),
    ("a byte appended", lambda n, v, all_: v + b"\0", "after the checksum"),
    ("wrong magic", lambda n, v, all_: b"X" + v[1:], "wrong magic"),
    ("format version 2", lambda n, v, all_: v[:12] + b"\x00\x02" + v[14:], "format version 2"),
    ("a bit flipped", lambda n, v, all_: v[:-60] + bytes([v[-60] ^ 4]) + v[-59:], "checksum mismatch"),
    ("another FMU", lambda n, v, all_: next(b for m, b in all_.items() if m != n), "saved by FMU"),
    ("another build", lambda n, v, all_: forge(n, v, lambda f: None, build="0123456789abcdef"), "another build"),
    ("a field missing", lambda n, v, all_: forge(n, v, lambda f: f.pop("_start_time")), "missing ['_start_time']"),
    ("a field added", lambda n, v, all_: forge(n, v, _set("__reduce__", 1.0)), "unexpected ['__reduce__']"),
    ("a string value", lambda n, v, all_: forge(n, v, _set("_start_time", "os.system")), "expected float, got str"),
    ("a bool as a float", lambda n, v, all_: forge(n, v, _set("_start_time", True)), "expected float, got bool"),
    ("an object", lambda n, v, all_: forge(n, v, _set("_stale", {"py/object": "os.system"})),
     "expected bool, got dict"),
    ("NaN time", lambda n, v, all_: forge(n, v, _set("_start_time", math.nan)), "nan is not finite"),
    ("infinite output", lambda n, v, all_: forge(n, v, _set(first(n, "output"), math.inf)), "inf is not finite"),
    ("parameter out of range", lambda n, v, all_: forge(n, v, _set(first(n, "parameter"), 1e300)),
     "invalid parameters"),
    ("running, not initialized", lambda n, v, all_: forge(n, v, _set("_initialized", False)), "_running without"),
]


def first(name, causality):
    return next(v.name for v in fmu_class(name).VARIABLES if v.causality == causality and v.type is float)


@pytest.mark.parametrize("name", list(FMUS))
def test_rejections_name_the_cause_and_leave_the_instance_usable(pair, blobs, name):
    inst, log, twin = pair(name)
    for what, make, reason in REJECTED:
        check_rejected(inst, log, make(name, blobs[name], blobs), reason)
    assert steps(inst, 20, 30) == steps(twin, 20, 30)


def test_another_fmus_state_in_memory_is_refused(pair):
    """fmi2SetFMUstate with a state pointer of another FMU: an error status, the instance unchanged and usable."""
    inst, log, twin = pair("Motor")
    other, _, _ = pair("Load")
    foreign = other.slave.getFMUstate()
    snapshot = serialized(inst)
    with pytest.raises(FMICallException) as exc:
        inst.slave.setFMUstate(foreign)
    assert exc.value.status == FATAL and "not one of this FMU's" in "\n".join(log)
    other.slave.freeFMUstate(foreign)
    assert serialized(inst) == snapshot
    assert steps(inst, 20, 30) == steps(twin, 20, 30)


def test_state_sequences_must_have_their_length(pair, blobs):
    inst, log, _ = pair("TwinJeffcottRotor")
    short = forge("TwinJeffcottRotor", blobs["TwinJeffcottRotor"], lambda f: f.update(_y=f["_y"][:-1]))
    check_rejected(inst, log, short, "field _y: expected 14 numbers")
    nan = forge("TwinJeffcottRotor", blobs["TwinJeffcottRotor"],
                lambda f: f.update(_y=(math.nan,) + f["_y"][1:]))
    check_rejected(inst, log, nan, "field _y: nan is not finite")


def test_derived_quantities_follow_the_restored_parameters(pair, blobs, fmu_dir):
    """A state saved with other parameters brings them back, and the derived quantities (the parameters object,
    the RK4 rates) are recomputed from them: the restored instance steps bitwise like one run with them."""
    params = {"k_theta": 40.0, "m_s": 2.0}
    ref_log = []
    ref = open_instance(fmu_dir, "DoubleCardanDriveline", ref_log, "reference")
    try:
        ref.initialize(params)
        steps(ref, 0, 20)
        blob = serialized(ref)
        expected = steps(ref, 20, 30)
    finally:
        ref.free()
    inst, log, _ = pair("DoubleCardanDriveline")       # default parameters
    assert restore(inst, log, blob) is None
    assert steps(inst, 20, 30) == expected


@pytest.mark.parametrize("name", list(FMUS))
def test_random_and_damaged_blobs(pair, blobs, name):
    inst, log, twin = pair(name)
    snapshot = serialized(inst)
    valid = blobs[name]
    damaged = st.one_of(
        st.binary(max_size=2 * len(valid)),
        st.integers(0, len(valid) - 1).map(lambda k: valid[:k]),
        st.integers(0, 8 * len(valid) - 1).map(lambda i: valid[:i // 8] + bytes([valid[i // 8] ^ (1 << i % 8)])
                                                + valid[i // 8 + 1:]),
        st.sampled_from([b for n, b in blobs.items() if n != name]),
        st.binary(max_size=64).map(lambda tail: valid[:len(valid) // 2] + tail))

    @SETTINGS
    @given(blob=damaged)
    def case(blob):
        CASES["bytes"] += 1
        check_outcome(inst, log, blob, snapshot)

    case()
    assert steps(inst, 20, 30) == steps(twin, 20, 30)


ODD_VALUES = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, None, True, 0, "x", [], [1.0], {}, 10 ** 30, -0.0, 1e300]),
    st.floats(allow_nan=True, allow_infinity=True), st.integers(), st.lists(st.floats(), max_size=20))


@pytest.mark.parametrize("name", list(FMUS))
def test_forged_blobs_with_a_valid_checksum(pair, blobs, name):
    inst, log, twin = pair(name)
    snapshot = serialized(inst)
    fields = list(base.decode_state(fmu_class(name), blobs[name]).fields)

    @SETTINGS
    @given(field=st.sampled_from(fields), value=ODD_VALUES, drop=st.booleans())
    def case(field, value, drop):
        CASES["forged"] += 1
        change = (lambda f: f.pop(field)) if drop and value is None else _set(field, value)
        check_outcome(inst, log, forge(name, blobs[name], change), snapshot)

    case()
    assert steps(inst, 20, 30) == steps(twin, 20, 30)


def test_json_bombs_are_rejected(pair):
    """Deep nesting, huge numbers and repeated fields in a blob with a valid checksum: rejected, never a crash."""
    inst, log, _ = pair("Load")
    for text in ("[" * 100000 + "]" * 100000, '{"a": ' + "9" * 5000 + "}", '{"_stale": true, "_stale": false}',
                 "\udc80", "[]"):
        blob = base.frame_state(b"Load", base.build_digest("load").encode(), text.encode(errors="surrogatepass"))
        check_rejected(inst, log, blob, "fields")


# --- the declaration of each model's state (Python level) ---

def run_python(cls, n=30):
    """An instance of cls (not through FMI) initialized and stepped n times with the shared input histories."""
    inst = cls(instance_name="py")
    inst.exit_initialization_mode()
    for k in range(n):
        for var in inst.VARIABLES:
            if var.causality == "input":
                setattr(inst, var.name, INPUTS[var.name](k * H))
        inst.get_real(list(inst._real_getters))
        assert inst.do_step(k * H, H)
    return inst


def _plain(value):
    """A derived value as plain data: a dataclass's compared fields (a cache declared compare=False, such as the
    double Cardan's ``outputs_memo``, fills as the FMU runs and is left out), else its attributes (with __slots__ or
    __dict__), else itself."""
    if dataclasses.is_dataclass(value):
        return {f.name: getattr(value, f.name) for f in dataclasses.fields(value) if f.compare}
    slots = getattr(type(value), "__slots__", None)
    if slots is not None:
        return {k: getattr(value, k) for k in slots}
    return getattr(value, "__dict__", value)


@pytest.mark.parametrize("name", list(FMUS))
def test_every_model_attribute_is_declared_state_or_derived(name):
    cls = fmu_class(name)
    inst = run_python(cls)
    declared = set(cls.STATE) | set(cls.DERIVED)
    assert not set(cls.STATE) & set(cls.DERIVED)
    model_attributes = set(vars(inst)) - set(vars(cls(instance_name="fresh")))
    assert model_attributes == declared, (sorted(model_attributes - declared), sorted(declared - model_attributes))
    for field, kind in cls.STATE.items():
        assert base._kind_error(kind, getattr(inst, field)) is None, (field, kind, getattr(inst, field))
    derived = {k: _plain(getattr(inst, k)) for k in cls.DERIVED}
    for k in cls.DERIVED:          # derive() alone must recreate them, equal after 30 steps (they do not evolve)
        delattr(inst, k)
    inst.derive()
    assert {k: _plain(getattr(inst, k)) for k in cls.DERIVED} == derived


def test_an_undeclared_attribute_makes_get_state_fail():
    inst = run_python(fmu_class("CardanJoint"), n=3)
    inst._cache = 1.0
    with pytest.raises(ValueError, match=r"\['_cache'\] are neither in STATE nor in DERIVED"):
        inst._get_fmu_state()


@pytest.mark.parametrize("name", list(FMUS))
def test_memory_and_serialized_states_restore_the_same_values(name):
    cls = fmu_class(name)
    state = run_python(cls)._get_fmu_state()
    decoded = cls._fmu_state_from_bytes(cls._fmu_state_to_bytes(state))
    assert decoded.origin == state.origin
    assert [(k, type(v), repr(v)) for k, v in decoded.fields.items()] == \
        [(k, type(v), repr(v)) for k, v in state.fields.items()]


def test_case_count():
    """Runs last in this file: how many hypothesis cases the tests above tried."""
    print(f"state cases tried: {CASES}")
    assert CASES["bytes"] >= len(FMUS) * EXAMPLES // 2 and CASES["forged"] >= len(FMUS) * EXAMPLES // 2
    assert CASES["accepted"] > 0          # forged values of the right kind and range are restored, exactly
