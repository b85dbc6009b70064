"""The C time loop: its build (:mod:`.build`), the glue generated per vehicle (:mod:`.glue`),
the stepper that drives it (:mod:`.stepper`) and the standalone solver export (:mod:`.export`)."""
