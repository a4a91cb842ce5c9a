"""Controllers behind one interface: state and reference in, joint torques out.

Each controller is a record (gains and the model it uses, as data) that also
gives the compiled simulator its ``kind`` code and parameter arrays; the law
itself is :func:`exoleg.control.laws.control_law`, one function for the
simulator and for Python callers alike.
"""

from exoleg.control.controllers import PD, ComputedTorque, Controller, PDGravity

__all__ = ["PD", "ComputedTorque", "Controller", "PDGravity"]
