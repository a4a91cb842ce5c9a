"""The analytic screen's closed forms (issue 39), each as an exact identity or against a
brute-force search (references: the forms' own derivations in ``design.screen``; the
heat balance they solve; the shipped device's figures, ``data/device/actuators``)."""

from __future__ import annotations

import numpy as np
import pytest

from exoleg.design import screen as s

MASSES = np.array([21.0, 32.0, 45.0])
TAU, QD, QDD = s.population_gait(MASSES, 2)  # the ankle: the largest moment and speed
J = 8.1e-5 + 7.9e-6   # EC 60 flat's rotor and a size-17 wave generator, kg m^2
ALPHA, ETA = 0.5, 0.8


def test_at_the_optimal_ratio_the_inertial_rms_equals_the_share_of_the_moment() -> None:
    n = s.optimal_ratio(J, ALPHA, TAU, QDD, ETA)
    assert np.allclose(J * n**2 * s.rms(QDD), ALPHA * s.rms(TAU) / ETA, rtol=1e-13, atol=0)


def test_the_optimal_ratio_is_the_brute_force_minimum_of_the_rms_torque() -> None:
    grid = np.linspace(5.0, 200.0, 39001)  # 0.005 apart
    torque = s.rms(s.motor_torque(J, grid[:, None], ALPHA, TAU[1], QDD, ETA))
    best = grid[np.argmin(torque)]
    assert best == pytest.approx(float(s.optimal_ratio(J, ALPHA, TAU[1], QDD, ETA)), abs=0.005)
    # and its square is the closed form's quadratic in N^2: the cross term independent of N
    n = 37.0
    q2, t2, qt = np.mean(QDD**2), np.mean(TAU[1] ** 2), np.mean(QDD * TAU[1])
    closed = J**2 * n**2 * q2 + 2 * J * ALPHA * qt / ETA + ALPHA**2 * t2 / (n * ETA) ** 2
    assert s.rms(s.motor_torque(J, n, ALPHA, TAU[1], QDD, ETA)) ** 2 == pytest.approx(
        closed, rel=1e-12)


def test_the_transparency_ratio_leaves_exactly_the_goal() -> None:
    goal = 0.036 * MASSES  # Lerner et al. 2018's upper bound, N m/kg x mass
    n = s.transparency_ratio(J, goal, QDD)
    assert np.allclose(s.residual(J, n, QDD), goal, rtol=1e-13, atol=0)


def test_the_winding_temperature_solves_its_heat_balance() -> None:
    # T = T_a + R_th R(T) I^2 with R(T) = R_25 (1 + a (T - 25)): plugged back, exactly
    i = np.array([2.0, 6.0, 9.0])
    r25, r_th, ta = 0.293, 3.8, 30.0
    t = s.winding_temperature(i, r25, r_th, ta)
    back = ta + r_th * r25 * (1 + s.COPPER_ALPHA * (t - 25.0)) * i**2
    assert np.allclose(t, back, rtol=1e-13, atol=0)
    # beyond 1 / (R_th R_25 a) no steady state: the winding runs away
    runaway = np.sqrt(1.0 / (r_th * r25 * s.COPPER_ALPHA)) * 1.01
    assert np.isinf(s.winding_temperature(runaway, r25, r_th, ta))


def test_the_screen_agrees_with_its_forms_candidate_by_candidate() -> None:
    motor = {"kt": np.array([0.0525, 0.0712])[:, None],
             "rotor_inertia": np.array([8.1e-5, 3.17e-4])[:, None],
             "r25": np.array([0.293, 0.213])[:, None], "r_th": np.array([3.8, 6.08])[:, None],
             "max_speed": np.array([6000.0, 5000.0])[:, None] * np.pi / 30,
             "max_winding_temperature": 125.0}
    ratios = np.array([[20.0, 50.0, 120.0]])
    r = s.screen(motor, ratios, ETA, 7.9e-6, TAU, QD, QDD, ALPHA, MASSES, 24.0, 30.0)
    assert r["fits"].shape == (2, 3, 3)
    for m in range(2):
        for g in range(3):
            for c in range(3):
                jm = motor["rotor_inertia"][m, 0] + 7.9e-6
                tm = s.motor_torque(jm, ratios[0, g], ALPHA, TAU[c], QDD, ETA)
                i = tm / motor["kt"][m, 0]
                assert r["current_rms"][m, g, c] == pytest.approx(s.rms(i), rel=1e-12)
                v = motor["r25"][m, 0] * i + motor["kt"][m, 0] * ratios[0, g] * QD
                assert r["voltage_peak"][m, g, c] == pytest.approx(np.abs(v).max(), rel=1e-12)
                assert r["residual_per_kg"][m, g, c] == pytest.approx(
                    jm * ratios[0, g] ** 2 * s.rms(QDD) / MASSES[c], rel=1e-12)
    # the shipped ankle (EC 60 flat through 1:120, 24 V) cannot follow a free-speed gait:
    # its rotor would turn beyond its 6,000 rpm (actuation-design.md: about 6,400 rpm at
    # a 1.0 s stride; at this 1.1 s stride, 120 x the ankle's peak rate)
    assert r["motor_speed_peak"][0, 2, 0] > 6000 * np.pi / 30 and not r["fits"][0, 2].any()


def test_a_spring_adds_the_torque_that_winds_it() -> None:
    # behind a series stiffness K the rotor leads the link by alpha tau / K: the motor's
    # torque is J N (qdd + alpha tau_dd / K) + alpha tau / (N eta), term by term
    tau_dd = s.periodic_second_derivative(TAU, 1.1, 10)
    rigid = s.motor_torque(2e-4, 50.0, 0.5, TAU, QDD, 0.8)
    soft = s.motor_torque(2e-4, 50.0, 0.5, TAU, QDD, 0.8, (300.0, tau_dd))
    assert np.allclose(soft - rigid, 2e-4 * 50.0 * 0.5 * tau_dd / 300.0, rtol=1e-12)
    # a stiffer spring winds less: the limit is the rigid gear
    stiff = s.motor_torque(2e-4, 50.0, 0.5, TAU, QDD, 0.8, (1e12, tau_dd))
    assert np.allclose(stiff, rigid, atol=1e-9)


def test_the_periodic_second_derivative_of_a_harmonic_is_exact() -> None:
    t = np.arange(100) / 100 * 1.1
    x = 3.0 * np.sin(2 * np.pi * 2 * t / 1.1) + 0.5 * np.cos(2 * np.pi * 12 * t / 1.1)
    d2 = s.periodic_second_derivative(x, 1.1, 10)  # the 12th harmonic left out
    assert np.allclose(d2, -3.0 * (2 * np.pi * 2 / 1.1) ** 2 * np.sin(2 * np.pi * 2 * t / 1.1),
                       atol=1e-9)


def test_the_loop_inertia_is_the_units_apparent_inertia() -> None:
    import dataclasses

    from exoleg.device.actuator import paper_actuators

    knee = dataclasses.replace(paper_actuators()[1], compliance="series_spring",
                               series_stiffness=300.0, torque_loop_bandwidth=30.0,
                               torque_loop_damping=0.7, deflection_bits=20)
    kp, _ = knee.torque_loop_gains
    assert s.loop_inertia(300.0, 30.0) == pytest.approx(knee.apparent_inertia, rel=1e-15)
    assert s.loop_inertia(300.0, 30.0) == pytest.approx(knee.reflected_inertia / (1 + kp),
                                                        rel=1e-12)
