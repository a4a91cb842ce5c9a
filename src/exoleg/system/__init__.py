"""The assembly floor: the device as its files configure it (:mod:`exoleg.system.config`)
and the one place a controller -- and, simulated, the device it drives -- is built from
that configuration, a leg, the child and the body mass. Above the controllers and the
simulated world (which never import each other); below the runs, the runtime and the
analyses that use what it builds."""
