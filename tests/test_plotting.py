"""Figures: a unit on every axis, the error in a panel of its own, no offset tick labels, titles inside the
figure, one display unit per quantity, a Campbell diagram only against a speed."""

import math
import re
from pathlib import Path

import matplotlib.figure
import numpy as np
import pytest

from ujfmu.plotting import DISPLAY_UNITS
from ujfmu.scenario import Scenario
from ujfmu.scenario_run import run_scenario
from ujfmu.sweep import Sweep, SweepSettings, parse_axis

SCENARIOS = Path(__file__).parents[1] / "scenarios"


@pytest.fixture
def figures(monkeypatch):
    """The figures the plotting functions save, drawn (so tick labels exist), by file name."""
    saved = {}
    original = matplotlib.figure.Figure.savefig

    def savefig(fig, path, **kwargs):
        original(fig, path, **kwargs)
        saved[Path(path).name] = fig

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    return saved


def check_readable(fig):
    """Every axis labelled with a unit in brackets (x on the bottom panels), no offset text, title inside."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    for ax in fig.axes:
        assert "[" in ax.get_ylabel() and ax.get_ylabel().endswith("]"), ax.get_ylabel()
        if ax.get_subplotspec().is_last_row():
            assert "[" in ax.get_xlabel() and ax.get_xlabel().endswith("]"), ax.get_xlabel()
        for axis in (ax.xaxis, ax.yaxis):
            offset = axis.get_offset_text().get_text()   # a multiplier (1e-5) may be; an offset (+0.03) not
            assert "+" not in offset, offset
    title = fig._suptitle.get_window_extent(renderer)
    box = fig.bbox
    assert box.x0 <= title.x0 and title.x1 <= box.x1 and title.y1 <= box.y1, (title, box)
    for ax in fig.axes:   # the panels' own titles too
        panel = ax.title if ax.get_title() else ax._left_title
        extent = panel.get_window_extent(renderer)
        assert box.x0 <= extent.x0 and extent.x1 <= box.x1, (panel.get_text(), extent, box)


def test_scenario_figures_have_units_an_error_panel_and_mm_for_lengths(fmu_dir, tmp_path, figures):
    # the first 0.6 s of twin_jeffcott_steady (orbits, spectra, lengths)
    text = (SCENARIOS / "twin_jeffcott_steady.toml").read_text()
    short = tmp_path / "twin_jeffcott_steady.toml"
    text = re.sub(r"(?m)^steady_from = .*$", "steady_from = 0.3", text)
    short.write_text(text.replace('file = "references/', f'file = "{SCENARIOS}/references/'))
    scenario = Scenario(short)
    scenario.stop_time = 0.6   # a part of the file's run (its verdict line says so)
    result = run_scenario(scenario, fmu_dir=fmu_dir, out_dir=tmp_path)
    assert result.scenario.stop_time == 0.6 and result.checked
    for name in ("twin_jeffcott_steady.png", "twin_jeffcott_steady_orbits.png", "twin_jeffcott_steady_spectra.png"):
        check_readable(figures[name])
    main = figures["twin_jeffcott_steady.png"]
    plotted = result.scenario.plot
    assert len(main.axes) == 2 * len(plotted)   # each signal, then its error below it in its own panel
    for i, name in enumerate(plotted):
        unit = DISPLAY_UNITS.get(result.scenario.unit(name), (result.scenario.unit(name),))[0]
        signal, error = main.axes[2 * i], main.axes[2 * i + 1]
        assert signal.get_title(loc="left").startswith(name) and signal.get_ylabel() == f"[{unit}]"
        assert error.get_ylabel() == f"error [{unit}]"
        # the error panel symmetric about zero with the allowed error in view, however small the error
        check = next(c for c in result.checks if c.name == name)
        k = DISPLAY_UNITS.get(result.scenario.unit(name), (None, 1.0))[1]
        low, high = error.get_ylim()
        assert low == -high
        assert k * check.allowed <= high <= 1.01 * k * max(1.25 * check.allowed, 1.05 * check.max_error)
    # lengths in mm in every figure: time plots, orbits and spectra alike
    assert main.axes[0].get_ylabel() == "[mm]"
    assert all(ax.get_xlabel().endswith("[mm]") for ax in figures["twin_jeffcott_steady_orbits.png"].axes)
    assert all(ax.get_ylabel() == "amplitude, zero-to-peak [mm]"
               for ax in figures["twin_jeffcott_steady_spectra.png"].axes)


def test_a_figure_names_a_failed_order_and_draws_the_error_where_it_is_checked(tmp_path, figures):
    """A run at 0.25 ms against a reference sampled every 1 ms: the error panel draws the error at the instants
    both hold, as the check compares (the reference interpolated between its samples would draw its own
    interpolation error, here 2% of a 2x at 35 samples a period); a failed order, which no panel's band shows, is
    named in its signal's title."""
    from types import SimpleNamespace

    from ujfmu.plotting import plot_scenario
    from ujfmu.scenario_run import OrderCheck
    scenario = Scenario(SCENARIOS / "cardan_constant_speed.toml")
    name = scenario.plot[0]
    run_t, ref_t = np.arange(0.0, 0.2 + 1e-9, 2.5e-4), np.arange(0.0, 0.2 + 1e-9, 1e-3)
    wave = lambda t: 60.0 + 5.0 * np.sin(2 * 90.0 * t)   # noqa: E731
    table = np.rec.fromarrays([run_t, wave(run_t)], names=["time", name])
    reference = np.rec.fromarrays([ref_t, wave(ref_t)], names=["time", name])
    result = SimpleNamespace(scenario=scenario, table=table, checks=[], extrapolated_checks=[], model_exchange=False,
                             order_checks=[OrderCheck(name, 2, 10.56, 10.0, 0.05), OrderCheck(name, 1, 1.0, 1.0, 0.05),
                                           OrderCheck(name, 4, 0.3, float("nan"), 0.05, note="n", refused=True)],
                             verdict="FAIL")
    plot_scenario(result, reference, tmp_path / "f.png")
    signal, error = figures["f.png"].axes[:2]
    assert figures["f.png"]._suptitle.get_text().startswith("FAIL: ")   # not after a wrapped title's last words
    assert signal.get_title(loc="left") == (f"{name}  (not compared)  (FAIL: 2x order +5.6%, allowed 5%, 4x order not "
                                            "resolved by the reference)")
    (line,) = error.get_lines()
    assert len(line.get_xdata()) == len(ref_t) and np.max(np.abs(line.get_ydata())) < 1e-9


def test_a_constant_signal_has_readable_ticks():
    """0.03 N.m to within round-off: ticks read 0.03, no '1e-12+2.999999999e-2' offset."""
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from ujfmu.plotting import _readable_limits
    fig, ax = plt.subplots()
    y = 0.03 + 1e-15 * np.sin(np.arange(100))
    ax.plot(y)
    _readable_limits(ax, y)
    FigureCanvasAgg(fig).draw()
    labels = [t.get_text() for t in ax.get_yticklabels()]
    plt.close(fig)
    assert ax.yaxis.get_offset_text().get_text() == "" and any(label.startswith("0.03") for label in labels), labels


@pytest.mark.parametrize("spec, campbell", [("motor.omega_set=1000,2000rpm", True),
                                            ("driveline.beta1,driveline.beta2=5,10deg", False)])
def test_campbell_diagram_only_against_a_speed(fmu_dir, tmp_path, figures, spec, campbell):
    """Order tracks (and, against a speed, a Campbell diagram) for every output, each on a log axis that a track
    of round-off does not stretch: the rigid double Cardan's joints cancel each other's odd orders, so its 1x
    amplitudes are ~1e-13 of its 2x ones."""
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")
    outputs = ["driveline.tau_in", "load.tau"]
    settings = SweepSettings.from_scenario(scenario, outputs=outputs, running_speed="motor.omega",
                                           settle_time=0.01, revolutions=1)
    sweep = Sweep(scenario, [parse_axis(spec, scenario)], settings, out_dir=tmp_path, fmu_dir=fmu_dir)
    sweep.run(workers=0)
    sweep.plot()
    for name in (f"{sweep.name}.png", f"{sweep.name}_orders.png"):
        check_readable(figures[name])
    orders = figures[f"{sweep.name}_orders.png"]
    assert len(orders.axes) == len(outputs) * (2 if campbell else 1)
    assert any("Campbell" in ax.get_title(loc="left") for ax in orders.axes) == campbell
    tracks = orders.axes[::2] if campbell else orders.axes
    for ax, out in zip(tracks, outputs):
        assert ax.get_title(loc="left").startswith(f"{out}: order tracks")
        low, high = ax.get_ylim()
        assert high / low < 1e8, (out, low, high)
    rows = sweep.table()
    assert max(r["driveline.tau_in.h1"] for r in rows) < 1e-6 * max(r["driveline.tau_in.h2"] for r in rows)
    assert figures[f"{sweep.name}.png"].axes[0].get_ylabel() == "[N.m]"
    swept = "motor.omega_set 1000..2000 rpm" if campbell else "driveline.beta1,driveline.beta2 5..10 deg"
    for name in (f"{sweep.name}.png", f"{sweep.name}_orders.png"):   # not the title's "2000 rpm input"
        title = figures[name]._suptitle.get_text().replace("\n", " ")
        assert swept in title and scenario.title not in title, title


def test_a_title_wraps_between_settings_not_inside_one():
    """'beta = 5 deg' and '684 rpm' stay on one line of a wrapped figure title."""
    from ujfmu.plotting import _title

    class Figure:
        def suptitle(self, text, fontsize):
            self.text = text

    text = "Twin Jeffcott rotor running below its first critical speed (684 rpm), beta = 5 deg, unbalanced discs"
    for width in range(20, len(text)):
        fig = Figure()
        _title(fig, text, width / 11.5)
        lines = fig.text.split("\n")
        assert any("beta = 5 deg" in line for line in lines) and any("684 rpm" in line for line in lines), lines
        assert fig.text.replace("\n", " ") == text


def test_campbell_diagram_shows_the_natural_frequencies(fmu_dir, tmp_path, figures):
    """The Campbell diagram of Omar's driveline carries its natural frequencies from the model's linearisation as
    labelled lines in Hz: Omar et al. publish the critical speeds 381 rpm (lateral) and 684 rpm (torsional), where
    the 2x excitation meets them, i.e. natural frequencies of 2 x 381 / 60 = 12.7 Hz and 2 x 684 / 60 = 22.8 Hz
    (sqrt(k/J) of their parameters). The torsional one, seen from the input through the joints, spans 138-148 rad/s
    over the input angle at beta0 = 15 deg (148.2 = 143.1 / cos(15 deg) at 0 deg, 3.5% high alone): the line is its
    mean, within 0.5% of the paper's, in a band of that range."""
    scenario = Scenario(SCENARIOS / "double_cardan_omar_torsional.toml")
    settings = SweepSettings.from_scenario(scenario, revolutions=2)
    sweep = Sweep(scenario, [parse_axis("motor.omega_set=300:700:400rpm", scenario)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.plot()   # no point run: the lines come from the model, not from the points
    campbell = figures[f"{sweep.name}_orders.png"].axes[1]
    legend = [t.get_text() for t in campbell.get_legend().get_texts()]
    assert "natural frequencies (at rest; input held: mean over the input angle, free: at angle 0)" in legend
    assert "their range over the input angle" in legend
    lines = sorted(line.get_ydata()[0] for line in campbell.get_lines() if line.get_linestyle() == ":")
    # lateral: sqrt(26331 / 4.09) = 80.24 rad/s is 383 rpm of 2x excitation, published as 381
    assert lines[0] == pytest.approx(2 * 381 / 60, rel=0.01) and lines[1] == pytest.approx(2 * 684 / 60, rel=0.005)
    # the band: sqrt(k/J) (Omar's k_theta = 92.2 N.m/rad, J = 0.0045 kg.m^2) times cos(beta0) at 90 deg and over
    # cos(beta0) at 0 deg, the joints' speed ratio at its extremes
    (band,) = campbell.patches   # the torsional mode's; the lateral one does not vary with the angle
    ys = campbell.transData.inverted().transform(band.get_verts())[:, 1]
    omega, cos_beta = math.sqrt(92.2 / 0.0045), math.cos(math.radians(15))
    assert ys.min() == pytest.approx(omega * cos_beta / (2 * math.pi), rel=2e-3)
    assert ys.max() == pytest.approx(omega / cos_beta / (2 * math.pi), rel=2e-3)
    labels = [t.get_text() for t in campbell.texts]
    assert labels == ["driveline: 12.77 Hz (80.24 rad/s, lateral)", "driveline: 22.78 Hz (143.1 rad/s, torsional)"]
    check_readable(figures[f"{sweep.name}_orders.png"])


def test_the_campbell_legend_covers_no_marker_and_no_mode_label(fmu_dir, tmp_path, figures):
    """The legend stands in a band left empty above the data: placed upper left, it had covered the 4x order's
    markers rising across the top and a mode's label (a fresh-eyes trial's sweep up to 1100 rpm); its markers are
    of one size, not the first point's."""
    scenario = Scenario(SCENARIOS / "double_cardan_omar_torsional.toml")
    settings = SweepSettings.from_scenario(scenario, revolutions=2, settle_time=0.5)
    sweep = Sweep(scenario, [parse_axis("motor.omega_set=600:1000:200rpm", scenario)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir, name="campbell_legend")
    sweep.run(workers=0, progress=False)
    sweep.plot()
    fig = figures[f"{sweep.name}_orders.png"]
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    for campbell in fig.axes[1::2]:
        legend = campbell.get_legend()
        box = legend.get_window_extent(renderer)
        markers = [xy for c in campbell.collections if len(c.get_offsets())
                   for xy in campbell.transData.transform(c.get_offsets())]
        assert max(xy[1] for xy in markers) > campbell.transData.transform((0, 60.0))[1]   # 4x up to 67 Hz
        assert not [xy for xy in markers if box.contains(*xy)]
        for label in campbell.texts:
            assert not box.overlaps(label.get_window_extent(renderer)), label.get_text()
        assert {float(h.get_sizes()[0]) for h in legend.legend_handles if hasattr(h, "get_sizes")} == {20.0}


def test_spectra_of_one_output_of_several_components_share_their_scale(tmp_path, figures):
    """The aligned and the misaligned rotor's X2 on one amplitude scale (the misaligned one's 2x stands 10x above
    the aligned one's 1x), their Y2 on another; each panel reaches 6 decades below its group's largest peak and
    names the mean it leaves out (the misaligned Y2's static offset of 0.03 mm)."""
    import numpy as np

    from ujfmu.plotting import plot_spectra
    from ujfmu.scenario_run import ScenarioResult
    scenario = Scenario(SCENARIOS / "twin_jeffcott_aligned_vs_misaligned.toml")
    t = np.arange(0.0, 20.0, 1e-3)
    turn = 70.0 * t
    signals = {"aligned.X2": 1e-5 * np.sin(turn), "misaligned.X2": 1e-4 * np.sin(2.0 * turn),
               "aligned.Y2": 2e-6 * np.cos(turn), "misaligned.Y2": 3e-5 + 1e-6 * np.cos(turn),
               "motor.omega": 70.0 + 0 * t}
    table = np.rec.fromarrays([t] + list(signals.values()), names=["time"] + list(signals))
    plot_spectra(ScenarioResult(scenario, table), tmp_path / "spectra.png")
    axes = {ax.get_title(loc="left").split(",")[0]: ax for ax in figures["spectra.png"].axes}
    head, mean, unit, tail = axes["misaligned.Y2"].get_title(loc="left").rsplit(" ", 3)
    assert (head, unit, tail) == ("misaligned.Y2, mean", "mm", "(removed)")
    assert float(mean) == pytest.approx(0.03, rel=1e-4)   # fitted with the orders: a plain mean read 0.02999
    assert axes["aligned.X2"].get_ylim() == axes["misaligned.X2"].get_ylim()
    assert axes["aligned.Y2"].get_ylim() == axes["misaligned.Y2"].get_ylim() != axes["aligned.X2"].get_ylim()
    low, high = axes["aligned.X2"].get_ylim()
    assert high == pytest.approx(3.0 * 1e3 * 1e-4, rel=0.05) and high / low == pytest.approx(3e6)   # mm


def test_the_order_figure_shows_the_first_outputs_and_says_so(fmu_dir, tmp_path, figures):
    """Seven outputs: the order figure has rows for the first ORDER_FIGURE_OUTPUTS (a figure a row an output
    would grow without bound) and its title says which it left out and how to choose."""
    from ujfmu.plotting import ORDER_FIGURE_OUTPUTS
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")
    outputs = [n for n in scenario.record if n != "driveline.phi_out"]
    assert len(outputs) == 7 > ORDER_FIGURE_OUTPUTS == 6
    settings = SweepSettings.from_scenario(scenario, outputs=outputs, running_speed="motor.omega",
                                           settle_time=0.01, revolutions=1)
    sweep = Sweep(scenario, [parse_axis("motor.omega_set=2000rpm", scenario)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.run(workers=0)
    sweep.plot()
    orders = figures[f"{sweep.name}_orders.png"]
    titles = [ax.get_title(loc="left") for ax in orders.axes[::2]]
    assert [t.split(":")[0] for t in titles] == outputs[:6]
    assert "(the first 6 of 7 outputs; --output chooses)" in orders._suptitle.get_text().replace("\n", " ")
    # one axis: the orders' one legend is placed clear of the tracks ("best", matplotlib's code 0), drawn once
    tracks = orders.axes[0]
    assert tracks.get_legend()._loc == 0 and not [a for a in tracks.artists if isinstance(a, type(tracks.get_legend()))]
    assert len(figures[f"{sweep.name}.png"].axes) == 7   # max and min: every output


def test_sweep_figures_say_what_they_leave_out_and_keep_every_title_inside(fmu_dir, tmp_path, figures):
    """A point that fails (RingCoupling needs e < R: e = R = 0.1 m) is marked in the max/min figure, whose panel
    titles stay inside the figure; the order figure, which draws the ok points only, says it left one out."""
    scenario = Scenario(SCENARIOS / "ring_coupling_fig3.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["coupling.x_e", "coupling.tau_in"],
                                           running_speed="motor.omega", settle_time=0.0, revolutions=1,
                                           steady_tol=0.0)
    sweep = Sweep(scenario, [parse_axis("coupling.e=0.001,0.05,0.1", scenario)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    assert [r["status"] for r in sweep.table()] == ["ok", "ok", "error"]
    sweep.plot()
    check_readable(figures[f"{sweep.name}.png"])
    assert all("points not ok marked" in ax.get_title(loc="left") for ax in figures[f"{sweep.name}.png"].axes)
    orders = figures[f"{sweep.name}_orders.png"]._suptitle.get_text().replace("\n", " ")
    assert f"not drawn: 1 point(s) not ok (marked in {sweep.name}.png)" in orders, orders


@pytest.mark.parametrize("speed_first", [True, False])
def test_the_order_tracks_show_each_value_of_the_other_axes(fmu_dir, tmp_path, figures, speed_first):
    """A speed x joint-angle grid: the tracks of every angle (a line style each, orders by colour, two legends),
    the Campbell diagram of the first angle, which its title names; nothing said to be left out. The speed is the
    abscissa whichever axis was given first."""
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["driveline.tau_in"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=1)
    axes = [parse_axis("motor.omega_set=1000,2000rpm", scenario),
            parse_axis("driveline.beta1,driveline.beta2=5,10deg", scenario)]
    sweep = Sweep(scenario, axes if speed_first else axes[::-1], settings, out_dir=tmp_path, fmu_dir=fmu_dir)
    sweep.run(workers=0)
    sweep.plot()
    fig = figures[f"{sweep.name}_orders.png"]
    check_readable(fig)
    tracks, campbell = fig.axes
    assert tracks.get_xlabel() == campbell.get_xlabel() == "motor.omega_set [rpm]"
    assert figures[f"{sweep.name}.png"].axes[-1].get_xlabel() == "motor.omega_set [rpm]"
    orders = len(settings.orders)
    assert len(tracks.get_lines()) == 2 * orders
    assert {line.get_linestyle() for line in tracks.get_lines()} == {"-", "--"}
    styles = tracks.get_legend()
    assert [t.get_text() for t in styles.get_texts()] == ["driveline.beta1,driveline.beta2 = 5 deg",
                                                         "driveline.beta1,driveline.beta2 = 10 deg"]
    assert campbell.get_title(loc="left").endswith("driveline.beta1,driveline.beta2 = 5 deg")
    assert "not drawn" not in fig._suptitle.get_text()


def test_sampled_rows_are_unjoined_points_in_the_order_figure_and_rows_sharing_x_are_named(fmu_dir, tmp_path,
                                                                                           figures):
    """Sampled rows (Axis.rows) are points, not a trend: the order tracks draw them as markers without a line
    between them, a marker per value of the other axes; rows that share their first value stand on one vertical,
    which the abscissa's label says (a 10/10 and a 10/-10 deg row read as one point before)."""
    from ujfmu.sweep import Axis
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["driveline.omega_out"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=1, steady_tol=0.0)
    rows = Axis.rows("driveline.beta1,driveline.beta2", [(10.0, 10.0), (8.0, 12.0), (10.0, -10.0)], "deg")
    sweep = Sweep(scenario, [rows, parse_axis("motor.omega_set=1000,2000rpm", scenario)], settings,
                  out_dir=tmp_path, fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    sweep.plot()
    tracks = figures[f"{sweep.name}_orders.png"].axes[0]
    drawn = [line for line in tracks.get_lines() if len(line.get_xdata()) == 3]
    assert drawn and {line.get_linestyle() for line in drawn} == {"None"}
    assert len({line.get_marker() for line in drawn}) == 2   # one per speed
    assert "points sharing it stand on one vertical" in tracks.get_xlabel()


def test_a_sweep_of_a_changed_copy_names_its_set_values_in_its_titles(fmu_dir, tmp_path, figures):
    """A `--set` sweep's figures read "the rest as in scenario <name>_changed" without the values set (a trial's
    K2Y = 60000): both titles give them after the scenario's name."""
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml").with_parameters({"load.T0": 3.5})
    settings = SweepSettings.from_scenario(scenario, outputs=["driveline.tau_in"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=1)
    sweep = Sweep(scenario, [parse_axis("motor.omega_set=1000,2000rpm", scenario)], settings, out_dir=tmp_path,
                  fmu_dir=fmu_dir)
    sweep.run(workers=0)
    sweep.plot()
    for name in (f"{sweep.name}.png", f"{sweep.name}_orders.png"):
        title = figures[name]._suptitle.get_text().replace("\n", " ")
        assert "the rest as in scenario double_cardan_brutti_rigid_changed (load.T0 = 3.5 N.m)" in title, title


def test_many_curves_are_named_beside_the_panels_each_distinct(fmu_dir, tmp_path, figures):
    """A three-axis grid (20 combinations of joint angle and yoke phase, a fresh-eyes trial's) had its legend of 20
    entries inside the first panel, crushing it, and its colours repeating after ten: the legend goes beside the
    panels, outside every panel, and no two curves share both colour and marker."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    scenario = Scenario(SCENARIOS / "double_cardan_brutti_rigid.toml")
    settings = SweepSettings.from_scenario(scenario, outputs=["driveline.omega_out"], running_speed="motor.omega",
                                           settle_time=0.01, revolutions=1, steady_tol=0.0)
    axes = [parse_axis("motor.omega_set=1000,2000rpm", scenario), parse_axis("driveline.beta1=5:25:5deg", scenario),
            parse_axis("driveline.yoke_phase=0:90:30deg", scenario)]
    sweep = Sweep(scenario, axes, settings, out_dir=tmp_path, fmu_dir=fmu_dir)
    sweep.run(workers=0, progress=False)
    sweep.plot()
    fig = figures[f"{sweep.name}.png"]
    check_readable(fig)
    (panel,) = fig.axes
    assert panel.get_legend() is None and len(fig.legends) == 1
    legend = fig.legends[0]
    assert len(legend.get_texts()) == 20
    renderer = FigureCanvasAgg(fig).get_renderer()
    outside = legend.get_window_extent(renderer)
    assert outside.x0 >= panel.get_window_extent(renderer).x1 and outside.x1 <= fig.bbox.x1
    maxima = panel.get_lines()[::2]
    assert len({(line.get_color(), line.get_marker()) for line in maxima}) == 20
