"""Omar, Rahim, Rejab's studies on the DoubleCardanDriveline FMU: critical speeds, load and misalignment trends,
lateral stiffness; and the committed docs/omar_study.md regenerates."""

import math

import numpy as np
import pytest

from ujfmu.build import REPO_DIR
from ujfmu.studies import omar

B15 = math.radians(15.0)


@pytest.fixture(scope="module")
def study(fmu_dir):
    s = omar.SteadyState(fmu_dir / "DoubleCardanDriveline.fmu")
    yield s
    s.close()


@pytest.fixture(scope="module")
def base(study):
    return omar.critical_speeds(study, beta1=B15, beta2=B15)


def test_critical_speeds_where_twice_the_input_speed_meets_each_natural_frequency(base):
    """Acceptance 3: sweep 100-1500 rpm at beta0 = 15 deg, 5 N.m; paper 684 and 381 rpm, within 3%."""
    t_rpm, l_rpm = base["torsional"][1][0], base["lateral"][1][0]
    assert t_rpm == pytest.approx(684.0, rel=0.03)
    assert l_rpm == pytest.approx(381.0, rel=0.03)
    assert t_rpm == pytest.approx(math.sqrt(92.2 / 0.0045) / 2 * 30 / math.pi, rel=0.01)
    assert l_rpm == pytest.approx(math.sqrt(26331.0 / 4.09) / 2 * 30 / math.pi, rel=0.01)
    # the peaks stand out of the sweep: resonances, not noise
    coarse = base["coarse"]
    lateral = np.array([r.misalignment_max for r in coarse])
    assert base["lateral"][1][1] > 5 * np.median(lateral)
    twist_amp = np.array([r.twist_max - r.twist_min for r in coarse])
    peak = min(base["torsional"][0], key=lambda r: abs(r.rpm - t_rpm))
    assert peak.twist_max - peak.twist_min > 3 * np.median(twist_amp)


def test_twist_linear_and_misalignment_quadratic_in_load_torque(study, base):
    """Acceptance 4, Table 2: 5 -> 15 N.m triples the twist, multiplies the dynamic misalignment by about 9."""
    t_rpm, l_rpm = base["torsional"][1][0], base["lateral"][1][0]
    twist = [study.response(t_rpm, load, beta1=B15, beta2=B15).twist_max for load in (5.0, 15.0)]
    lateral = [study.response(l_rpm, load, beta1=B15, beta2=B15).misalignment_max for load in (5.0, 15.0)]
    assert twist[1] / twist[0] == pytest.approx(3.0, rel=0.02)        # paper 11.58/3.87 = 2.99
    assert lateral[1] / lateral[0] == pytest.approx(9.0, rel=0.05)    # paper 0.0915/0.0102 = 8.97


def test_amplification_rises_with_static_misalignment(study, base):
    """Acceptance 4, Fig. 8: 15 -> 30 deg raises both amplitudes, the lateral more than the torsional."""
    t_rpm, l_rpm = base["torsional"][1][0], base["lateral"][1][0]
    rows = []
    for deg in (15, 20, 25, 30):
        b = math.radians(deg)
        rows.append((study.response(t_rpm, 5.0, beta1=b, beta2=b).twist_max,
                     study.response(l_rpm, 5.0, beta1=b, beta2=b).misalignment_max))
    twist, lateral = np.array(rows).T
    assert np.all(np.diff(twist) > 0) and np.all(np.diff(lateral) > 0)
    assert lateral[-1] / lateral[0] > twist[-1] / twist[0] > 1.3


@pytest.mark.parametrize("k_phi,paper_rpm", [(13166.0, 270.0), (39497.0, 468.0)])
def test_lateral_critical_speed_moves_with_support_stiffness(study, base, k_phi, paper_rpm):
    """Acceptance 4, Figs. 11-12; softer support: lower critical speed, larger peak; the twist is unchanged."""
    res = omar.critical_speeds(study, coarse=np.arange(150.0, 651.0, 50.0), beta1=B15, beta2=B15, k_phi=k_phi)
    rpm, value = res["lateral"][1]
    assert rpm == pytest.approx(paper_rpm, rel=0.03)
    softer = k_phi < 26331.0
    assert (value > base["lateral"][1][1]) == softer
    t_rpm = base["torsional"][1][0]
    assert study.response(t_rpm, 5.0, beta1=B15, beta2=B15, k_phi=k_phi).twist_max == pytest.approx(
        base["torsional"][1][1], rel=0.01)


def test_committed_study_report_regenerates(fmu_dir, tmp_path):
    fresh = omar.write_report(tmp_path / "omar_study.md", fmu_path=fmu_dir / "DoubleCardanDriveline.fmu",
                              progress=lambda *_: None)
    assert fresh.read_text() == (REPO_DIR / "docs" / "omar_study.md").read_text()
