"""The device's actuation judged for the children it is for (an analyses floor): what the
joints demand of the actuators over the gait (:mod:`~exoleg.design.demand`), the
fit and the actuators' margins across a population of children
(:mod:`~exoleg.design.population`), and one child's fitting report
(:mod:`~exoleg.design.report`). Built on the sizing (the child's body, the fit) below
and the batch simulation of the runs floor."""
