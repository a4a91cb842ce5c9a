"""What a person may type, in the units they type: the bounds for a child that the command
line (``exoleg fit``) and the operator interface share before :class:`exoleg.sizing.Child`
checks the values against the growth charts, and the names of the controllers. Kept free
of imports so that the command line's parser stays fast."""

#: The paper's laws by name (:func:`exoleg.control.controllers.law_named`), and the
#: controllers a session on a device may run: the walking hierarchy or a law following
#: a reference (:class:`exoleg.control.tracking.TrackingController`).
LAWS = ("pd-gravity", "pd", "computed-torque")
CONTROLLERS = ("walk", *LAWS)

#: name -> (lowest, highest, unit); "measured": any measured dimension
CHILD_ENTRY = {"age": (2.0, 20.0, "years"), "height": (50.0, 220.0, "cm"),
               "mass": (5.0, 200.0, "kg"), "measured": (1.0, 200.0, "cm")}
#: the dimensions that may be measured (Child's fields, m; typed in cm)
MEASURED = ("thigh", "shank", "leg_length", "foot_length", "ankle_height")
#: the walking simulation's child (``exoleg simulate --walk``, ``exoleg run`` and the
#: operator interface's sessions): body mass bounds and the mass without a fitted child
BODY_MASS = (10.0, 150.0, "kg")
DEFAULT_BODY_MASS = 30.0
