"""Vibration protocol: driven rotation at constant input speed under a constant output load.

The response of declared body coordinates (output torsion = TE of Eq. (obs_te),
a wheel translation, ...) is recorded at every accepted step of the implicit
run. Accepted steps may be adaptive, so spectra are taken on a uniform time
grid (linear resampling) and shaft-order spectra on a uniform grid of the
unwrapped input phase. Markers: the pin-mesh frequency f_mesh = z_p f_in
(the configuration of a fixed-ring cycloid stage repeats, in the output frame,
every 2 pi / z_p of input rotation) and the rolling-bearing frequencies
(cage FTF, ball/roller pass BPFO and BPFI, ball spin BSF) of each bearing at
its relative ring speed.
"""
import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from .. import progress
from ..errors import RvtoolInputError
from ..validation import check_positive
from ..solver.continuation import Continuation
from .precision import transmission_error


@dataclass(frozen=True, kw_only=True)
class VibrationProtocol:
    """Driven rotation: boundary conditions, load and sampling.

    speed_rpm: constant input speed [rpm]. torque: output load [N m] (resisting).
    duration: simulated time [s]. sample_step: uniform resampling step [s]
    (None: the run's nominal step). samples_per_rev: points per input revolution
    of the order resampling [-].
    """
    speed_rpm: float
    torque: float
    duration: float
    sample_step: float | None = None
    samples_per_rev: int = 400

    def __post_init__(self):
        check_positive("speed_rpm", self.speed_rpm)
        check_positive("duration", self.duration)
        if self.sample_step is not None:
            check_positive("sample_step", self.sample_step)
        if self.samples_per_rev < 8:
            raise RvtoolInputError(f"samples_per_rev = {self.samples_per_rev} is outside the valid range [8, inf)")

    @property
    def input_frequency_hz(self):
        return self.speed_rpm / 60.0


# -- signal processing -------------------------------------------------------------------

def uniform_resample(t, x, dt):
    """Linear resampling of x(t) (strictly increasing t) on t0 + k dt, k = 0..; returns (t_u, x_u)."""
    t = np.asarray(t, float)
    if np.any(np.diff(t) <= 0):
        raise RvtoolInputError("t must be strictly increasing for resampling")
    check_positive("dt", dt)
    n = int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    t_u = t[0] + dt * np.arange(n)
    return t_u, np.interp(t_u, t, np.asarray(x, float))


def amplitude_spectrum(x, dt, *, remove_mean=True):
    """One-sided amplitude spectrum of uniformly sampled x: (frequencies [Hz], amplitudes).
    A sine of amplitude A on a bin frequency (integer periods in the record) gives A."""
    x = np.asarray(x, float)
    if remove_mean:
        x = x - x.mean()
    n = len(x)
    amp = np.abs(np.fft.rfft(x)) * 2.0 / n
    amp[0] *= 0.5
    if n % 2 == 0:
        amp[-1] *= 0.5
    return np.fft.rfftfreq(n, dt), amp


def order_spectrum(phase, x, samples_per_rev=400, *, remove_mean=True):
    """Shaft-order spectrum: x resampled on a uniform grid of the unwrapped shaft phase
    [rad] (whole revolutions only); returns (orders [-], amplitudes). Order spacing is
    1 / (number of revolutions)."""
    phase = np.unwrap(np.asarray(phase, float))
    if phase[-1] < phase[0]:
        phase, x = -phase, x
    n_rev = int(np.floor((phase[-1] - phase[0]) / (2 * np.pi) + 1e-9))
    if n_rev < 1:
        # a partial revolution: use it whole, orders spaced by its fraction
        span = phase[-1] - phase[0]
        n = max(8, int(samples_per_rev * span / (2 * np.pi)))
    else:
        span = n_rev * 2 * np.pi
        n = n_rev * samples_per_rev
    grid = phase[0] + span * np.arange(n) / n
    xu = np.interp(grid, phase, np.asarray(x, float))
    f, amp = amplitude_spectrum(xu, span / n / (2 * np.pi), remove_mean=remove_mean)
    return f, amp


def dominant(freqs, amp, n=5):
    """The n largest local maxima: (positions, amplitudes), largest first."""
    amp = np.asarray(amp)
    if len(amp) < 3:
        return np.asarray(freqs)[:0], amp[:0]
    idx = np.flatnonzero((amp[1:-1] >= amp[:-2]) & (amp[1:-1] >= amp[2:])) + 1
    idx = idx[np.argsort(amp[idx])[::-1][:n]]
    return np.asarray(freqs)[idx], amp[idx]


# -- marker frequencies -------------------------------------------------------------------

def body_mode_markers(ax, markers, key="wheel_modes_hz", label="wheel modes", color="m"):
    """Vertical markers at the flexible bodies' modes (``markers[key]``, a list [Hz], as
    :meth:`rvtool.assembly.cycloid.CycloidModel.marker_frequencies` gives them: ``wheel_modes_hz``,
    and for flexible RV cranks ``crank_modes_hz``; absent: nothing drawn) on a spectrum axis, with
    one legend entry."""
    for i, f in enumerate(markers.get(key, ()) if isinstance(markers, dict) else ()):
        ax.axvline(f, color=color, ls="-.", lw=0.7, label=label if i == 0 else None)


def marker_frequencies(model, speed_rpm):
    """Mesh and bearing marker frequencies [Hz] of ``model`` at input speed [rpm] (the
    topology lists its own markers)."""
    return model.marker_frequencies(speed_rpm)


# -- driven run ---------------------------------------------------------------------------

def driven_response(model, protocol: VibrationProtocol, run_spec, *, coordinates=(), out_dir=None, observers=None,
                    static_tolerances=None, initial_state=None):
    """Run the protocol on ``model`` from the loaded quasi-static state at input angle 0.

    coordinates: dict name -> (body, coord) of recorded responses [m or rad]; the
    output torsion (TE [rad]) is always recorded as "torsion".
    static_tolerances: (abs_tol [N], rel_tol [-]) of the loaded start's static solve (None: the
    StaticSolver defaults; float32 contact evaluation needs rel_tol >= 1e-6).
    initial_state: q0 to start from instead of the static solve (e.g. a float64 equilibrium
    for a float32 run).
    Returns times, input phase, responses on the accepted steps and the run record.
    """
    import exudyn as exu

    from ..solver import simulate
    omega = protocol.speed_rpm * 2 * np.pi / 60.0
    ratio = model.ratio
    torque = -np.sign(ratio) * protocol.torque
    if initial_state is None:
        # loaded start by torque continuation (increment halving, jump guard): a full-load
        # Newton solve from the kinematic state can converge to a spurious far equilibrium
        cont = Continuation(model, input_angle=0.0)
        if static_tolerances is not None:
            st = cont.static.settings.staticSolver.newton
            st.absoluteTolerance, st.relativeTolerance = static_tolerances
        q0 = cont.go_to(torque)
    else:
        model.set_output_torque(torque)
        q0 = np.array(initial_state, float)
    v0 = model.body_vector(model.kinematic_state(0.0, omega).velocities)
    mbs = model.mbs
    model.set_input_speed(omega)
    mbs.Assemble()
    mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
    mbs.systemData.SetODE2Coordinates_t(v0, configuration=exu.ConfigurationType.Initial)
    coords = dict(coordinates)
    idx = {name: model.coordinate_index(b, c) for name, (b, c) in coords.items()}
    i_out, i_in = model.output_index, model.input_index
    ref_out = model.reference_value(model.output)
    rec_t, rec_in, rec_out = [0.0], [q0[i_in]], [ref_out + q0[i_out]]
    rec_x = {n: [q0[i]] for n, i in idx.items()}

    spec = dataclasses.replace(run_spec, end_time=protocol.duration)
    t0 = time.perf_counter()
    with progress.task(protocol.duration, desc="driven run", unit="s") as advance:
        def record(t, q, v):
            rec_t.append(t)
            rec_in.append(q[i_in])
            rec_out.append(ref_out + q[i_out])
            for n, i in idx.items():
                rec_x[n].append(q[i])
            advance(t)

        rec = simulate(mbs, spec, model.contact_elements(), observers, before_accept=record, out_dir=out_dir)
    t, th_in, th_out = map(np.array, (rec_t, rec_in, rec_out))
    resp = {"torsion": transmission_error(th_in, th_out, ratio)}
    resp.update({n: np.array(x) for n, x in rec_x.items()})
    return {"t": t, "phase_in": th_in, "responses": resp, "record": rec, "wall_s": time.perf_counter() - t0}


def vibration_spectra(run, protocol: VibrationProtocol, name="torsion", dt=None):
    """Uniform-time and shaft-order spectra of response ``name`` of a :func:`driven_response` run."""
    t, x = run["t"], run["responses"][name]
    dt = dt or protocol.sample_step or float(np.median(np.diff(t)))
    t_u, x_u = uniform_resample(t, x, dt)
    f, a = amplitude_spectrum(x_u, dt)
    o, ao = order_spectrum(run["phase_in"], x, protocol.samples_per_rev)
    return {"t_uniform": t_u, "x_uniform": x_u, "frequencies_hz": f, "spectrum": a, "orders": o,
            "order_spectrum": ao}
