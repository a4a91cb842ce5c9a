"""What a person may type, in the units they type: the bounds for a child that the command
line (``exoleg fit``) and the operator interface share before :class:`exoleg.sizing.Child`
checks the values against the growth charts, and the names of the controllers. Kept free
of imports so that the command line's parser stays fast."""

#: The paper's laws by name (:func:`exoleg.control.controllers.law_named`); the walking
#: controller's support modes (:class:`exoleg.control.transparency.SupportMode`); and the
#: controllers a session on a device may run: the walking hierarchy -- ``walk`` is it in
#: its impedance mode -- starting in a support mode, or a law following a reference
#: (:class:`exoleg.control.tracking.TrackingController`).
LAWS = ("pd-gravity", "pd", "computed-torque")
SUPPORT_MODES = ("impedance", "transparent", "aan")
#: assist-as-needed's laws (:data:`exoleg.control.assist.LAWS`)
ASSIST_LAWS = ("error", "proportional")
WALKING_CONTROLLERS = ("walk", *SUPPORT_MODES)
CONTROLLERS = (*WALKING_CONTROLLERS, *LAWS)
#: The hip motor's variants (``data/device/hip-variants``): the paper's 220 W EC 90 flat
#: is rated on no maxon page; the shipped hip is the 160 W (the paper's assumption).
HIP_VARIANTS = ("ec90flat-90w", "ec90flat-160w", "ec90flat-260w")

#: name -> (lowest, highest, unit); "measured": any measured dimension
CHILD_ENTRY = {"age": (2.0, 20.0, "years"), "height": (50.0, 220.0, "cm"),
               "mass": (5.0, 200.0, "kg"), "measured": (1.0, 200.0, "cm")}
#: the dimensions that may be measured (Child's fields, m; typed in cm)
MEASURED = ("thigh", "shank", "leg_length", "foot_length", "ankle_height")
#: the walking simulation's child (``exoleg simulate --walk``, ``exoleg run`` and the
#: operator interface's sessions): body mass bounds and the mass without a fitted child
BODY_MASS = (10.0, 150.0, "kg")
DEFAULT_BODY_MASS = 30.0


def typed_number(label: str, value: object) -> float:
    """What a person typed in the field ``label`` as a number: a number, or text with a
    decimal point or a decimal comma ("26,5" is 26.5). Raises ValueError in the form's
    words when it is empty, not a number, ambiguous ("1,234.5", "1.234,5": which is the
    decimal mark?) or not finite."""
    import math

    if isinstance(value, bool):
        raise ValueError(f"{label}: expected a number, got {value!r}")
    if isinstance(value, (int, float)):
        try:
            x = float(value)
        except OverflowError:  # an int beyond any float
            raise ValueError(f"{label}: {str(value)[:20]}... is too large a number") from None
    else:
        text = str(value if value is not None else "").strip()
        if not text:
            raise ValueError(f"{label}: empty; enter a number")
        if "," in text and "." in text or text.count(",") > 1:
            raise ValueError(f"{label}: {text[:20]!r} mixes ',' and '.'; write one decimal "
                             "mark (26.5 or 26,5)")
        try:
            x = float(text.replace(",", "."))
        except ValueError:
            raise ValueError(f"{label}: {text[:20]!r} is not a number") from None
    if not math.isfinite(x):
        raise ValueError(f"{label}: {x!r} is not a finite number")
    return x
