"""A control law of your own for exoleg (docs/extending/controller.md): PD with gravity
compensation whose damping makes each joint critically damped about the standing
posture.

    u = Kp (q_ref - q) + Kd (dq_ref - dq) + G(q),   Kd_i = 2 sqrt(Kp_i M_ii(0))

M and G are the leg model exoleg hands the factory: the child + device leg with the
actuators' reflected inertia (N^2 J) on its diagonal. With the paper's Kd instead
(``kd=``), it is the paper's eq 23, exoleg's own ``pd-gravity``.

Run it: ``exoleg run --backend sim --controller examples/controllers/critical_pd.py:CriticalPD
--duration 6 --arm --walk-after 2 --out my-session``.
"""

import numpy as np

#: the paper's stiffness, N m/rad (section 6: Kp = diag(80, 80, 50))
KP = (80.0, 80.0, 50.0)


class CriticalPD:
    """PD + gravity compensation, critically damped per joint at the standing posture."""

    def __init__(self, leg, kp=KP, kd=None):
        self.leg = leg
        self.kp = np.array(kp, dtype=float)
        self.kd = self.critical() if kd is None else np.array(kd, dtype=float)

    def critical(self):
        """Kd_i = 2 sqrt(Kp_i M_ii) at the standing posture (q = 0), N m s/rad."""
        return 2.0 * np.sqrt(self.kp * np.diag(self.leg.M(np.zeros(3))))

    def torque(self, q, dq, q_ref, dq_ref, ddq_ref):
        """The torque (3,) N m for this tick: exoleg's safety layer comes after it."""
        return self.kp * (q_ref - q) + self.kd * (dq_ref - dq) + self.leg.G(q)

    def gains_now(self):
        return {"Kp": self.kp.tolist(), "Kd": self.kd.tolist()}

    def set_gains(self, change):
        """A new Kp keeps each joint critically damped (Kd follows it)."""
        kp = np.array(change.get("Kp", self.kp), dtype=float)
        if kp.shape != (3,) or not np.all((kp >= 0) & (kp <= 1e4)):
            raise ValueError(f"Kp: 3 values of 0-1e4 N m/rad, got {kp.tolist()}")
        self.kp = kp
        self.kd = self.critical()
