"""Latches from `hinge_properties`: the event time, the plastic impact and the compliant latch,
each against a hand-computed answer.

Models are small .dep texts compiled here. Conventions: docs/deployment.md.
"""

import numpy as np
import pytest
from scipy.integrate import quad

from depsim.runtime import simulate

# Two bars in zero gravity: bar1 pinned to the ground, bar2 pinned to bar1's tip and folding
# about it at 3 rad/s from straight; h2 latches at 90 degrees.
L1, M1, J1 = 1.0, 10.0, 1.0
L2, M2, J2 = 0.8, 1.5, 0.1
OMEGA0 = 3.0
TWO_BARS = f"""model two_bars "two bars folding to a latch"
bar bar1 {{ length = {L1} m; mass = {M1} kg; inertia = {J1} kg*m^2 }}
bar bar2 {{ length = {L2} m; mass = {M2} kg; inertia = {J2} kg*m^2 }}
hinge h1 joins ground.origin to bar1.a
hinge h2 joins bar1.b to bar2.a {{
    latch = 90 deg
}}
initial {{ h2.rate = {OMEGA0} rad/s }}
simulate {{ t_end = 1.5 s; tol = 1e-11; dt_out = 0.01 s }}
output theta1 = h1
output theta2 = h2
output rate1 = h1.rate
output rate2 = h2.rate
"""

# One bar driven by a constant spring torque P into a compliant latch at 90 degrees.
J_O = 0.25 + 3 * 0.25  # inertia about the hinge, kg m^2
PRELOAD = 1.0
COMPLIANT = """model springy "a bar driven into a compliant latch"
bar arm {{ length = 1 m; mass = 3 kg; inertia = 0.25 kg*m^2 }}
hinge h joins ground.origin to arm.a {{
    preload = {P} N*m
    latch = 90 deg
    latch_stiffness = {K} N*m/rad
    latch_damping = {C} N*m*s/rad
}}
simulate {{ t_end = {T} s; tol = 1e-10; dt_out = 0.005 s }}
output theta = h
output omega = h.rate
"""



def two_bar_reference():
    """Angular momentum H about the ground pin and kinetic energy T are conserved until the
    latch; at relative angle theta (c = cos theta) with A = J1 + m1 d1^2 + m2 L1^2,
    B = J2 + m2 d2^2, C = m2 L1 d2 c, I = A + B + 2C (inertia about the pin):
    T = H^2 / (2 I) + (B - (B + C)^2 / I) r^2 / 2, r the relative rate. So r(theta) is known and
    the latch time is the integral of dtheta / r from 0 to 90 degrees. After the latch the two
    bars turn as one body at Omega = H / I(90 deg)."""
    d1, d2 = L1 / 2, L2 / 2
    A, B = J1 + M1 * d1 ** 2 + M2 * L1 ** 2, J2 + M2 * d2 ** 2

    def parts(theta):
        C = M2 * L1 * d2 * np.cos(theta)
        inertia = A + B + 2 * C
        return inertia, B + C

    _, coupling0 = parts(0.0)
    H = coupling0 * OMEGA0  # omega1 = 0, omega2 = OMEGA0 at the start
    T = 0.5 * B * OMEGA0 ** 2

    def rate(theta):
        inertia, coupling = parts(theta)
        return np.sqrt((T - H * H / (2 * inertia)) * 2 / (B - coupling ** 2 / inertia))

    t_latch, _ = quad(lambda th: 1.0 / rate(th), 0.0, np.pi / 2, epsabs=1e-14, epsrel=1e-13)
    inertia, coupling = parts(np.pi / 2)
    r_before = rate(np.pi / 2)
    omega1_before = (H - coupling * r_before) / inertia
    omega2_before = omega1_before + r_before
    Omega = H / inertia
    return {"t": t_latch, "rate": r_before, "Omega": Omega, "B": B,
            "omega1": omega1_before, "omega2": omega2_before,
            "loss": T - 0.5 * inertia * Omega ** 2, "d2": d2}


def test_two_bar_latch_time_rates_impulse_and_energy_by_hand(build):
    module = build(TWO_BARS)
    result = simulate(module)
    ref = two_bar_reference()
    (latch,) = [e for e in result.events if e.name == "h2.latch"]
    assert (latch.kind, latch.hinge) == ("latch", "h2")  # what the record is, not its name
    # the latch time: quadrature of the conserved H and T (independent of any integrator)
    assert abs(latch.t - ref["t"]) < 1e-9
    assert latch.data["rate"] == pytest.approx(ref["rate"], rel=1e-9)
    # plastic impact: the bars turn as one body at H / I, the kinetic energy lost is T - H^2/2I
    after = result.times > latch.t + 1e-6
    assert np.allclose(result.output("rate1")[after], ref["Omega"], rtol=1e-9)
    assert np.max(np.abs(result.output("rate2")[after])) < 1e-9
    assert latch.data["impact_energy_loss"] == pytest.approx(ref["loss"], rel=1e-8)
    # the latch's angular impulse on bar2: bar2's Newton-Euler equations over the impact give
    # (J2 + m2 d2^2) (Omega - omega2-), and the pin impulse m2 |dv_c2| with
    # v_c2 = (-d2 omega2, L1 omega1) in bar1's frame
    assert latch.data["impulse"] == pytest.approx(ref["B"] * (ref["Omega"] - ref["omega2"]),
                                                  rel=1e-8)
    dv = np.array([-ref["d2"] * (ref["Omega"] - ref["omega2"]),
                   L1 * (ref["Omega"] - ref["omega1"])])
    assert latch.data["joint_impulses"]["h2"] == pytest.approx(M2 * np.hypot(*dv), rel=1e-8)
    # energy: kinetic + lost in the impact is constant
    assert np.max(np.abs(result.total_energy() - result.total_energy()[0])) < 1e-9
    assert result.deployment.deployed and result.deployment.time == latch.t


def test_the_event_is_located_on_the_dense_output_to_1e9_s(build):
    """A run without latches stopped at the located time ends (a real step end, not dense
    output) at the latch angle to within |rate| * 1e-9 s."""
    module = build(TWO_BARS)
    t_latch = next(e.t for e in simulate(module).events if e.name == "h2.latch")
    free = simulate(module, t_end=t_latch, mechanics=False)
    miss = free.output("theta2")[-1] - np.pi / 2
    assert abs(miss) < 1e-9 * abs(free.output("rate2")[-1])


def test_a_rigid_latch_holds_at_all_three_levels(build):
    module = build(TWO_BARS)
    result = simulate(module)
    t_latch = result.events[0].t
    after = result.times > t_latch
    assert "h2.latch" in result.constraint_names
    assert np.max(np.abs(result.output("theta2")[after] - np.pi / 2)) < 1e-12
    assert np.max(np.abs(result.output("rate2")[after])) < 1e-12
    # acceleration level at every step point, where lambda is exact (at the output times
    # lambda is the step's linear interpolation: docs/method.md, section 5)
    assert result.stats.max_v_acc < 1e-9
    # after the latch nothing but the pin loads the bars: the lock carries a torque
    # only through the centripetal loads, and T = -lambda_lock
    lock = result.lam[:, result.constraint_names.index("h2.latch")]
    assert np.all(np.isnan(lock[~after])) and np.all(np.isfinite(lock[after]))
    assert np.allclose(result.hinge_loads["h2"].torque[after], -lock[after])


def compliant_peak(stiffness: float) -> tuple[float, float]:
    """Rate at the latch omega_l = sqrt(2 P theta_l / J_O) (constant torque from rest); then
    J_O delta'' = P - K delta: the largest overshoot delta_max = P/K + sqrt((P/K)^2 +
    J_O omega_l^2 / K) and the peak latch torque K delta_max."""
    omega_l = np.sqrt(2 * PRELOAD * (np.pi / 2) / J_O)
    delta_max = PRELOAD / stiffness + np.sqrt((PRELOAD / stiffness) ** 2
                                              + J_O * omega_l ** 2 / stiffness)
    return omega_l, stiffness * delta_max


@pytest.mark.parametrize("stiffness", [200.0, 800.0])
def test_compliant_latch_loads_depend_on_its_stiffness(build, stiffness):
    module = build(COMPLIANT.format(P=PRELOAD, K=stiffness, C=0.0, T=6.0))
    result = simulate(module)
    omega_l, peak = compliant_peak(stiffness)
    first = result.events[0]
    assert first.name == "h.latch" and first.data["rigid"] is False
    assert first.t == pytest.approx(np.sqrt(2 * (np.pi / 2) * J_O / PRELOAD), abs=1e-9)
    assert first.data["rate"] == pytest.approx(omega_l, rel=1e-9)
    # the peak is sampled at the steps: within (Omega h)^2 of the true one
    assert result.peak_loads["h"].torque == pytest.approx(peak, rel=2e-3)
    # without damping the bar bounces off the latch and comes back: contact / separation
    names = [e.name for e in result.events]
    assert "h.latch.separation" in names and "h.latch.contact" in names
    kinds = {e.name: (e.kind, e.hinge) for e in result.events}
    assert kinds["h.latch.separation"] == ("latch.separation", "h")
    assert kinds["h.latch.contact"] == ("latch.contact", "h")
    # energy, with the latch spring's potential: constant (1e-7 of the 1.6 J of spring work:
    # the output times sample the dense output, the step points are closer)
    assert "latch.h" in result.energy_names
    assert np.max(np.abs(result.total_energy() - result.total_energy()[0])) < 1e-7


def test_a_damped_compliant_latch_dissipates_what_the_energy_balance_misses(build):
    module = build(COMPLIANT.format(P=PRELOAD, K=400.0, C=60.0, T=4.0))
    result = simulate(module)
    assert "latch.h" in result.dissipator_names
    lost = result.dissipated[-1, result.dissipator_names.index("latch.h")]
    assert lost > 0.1
    assert np.max(np.abs(result.total_energy() - result.total_energy()[0])) < 1e-7
    # the damper settles the bar against the latch at the static overshoot P / K
    assert result.output("theta")[-1] == pytest.approx(np.pi / 2 + PRELOAD / 400.0, abs=1e-4)
    assert result.hinge_loads["h"].torque[-1] == pytest.approx(-PRELOAD, abs=1e-2)
