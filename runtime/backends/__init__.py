"""The compiled backends: the compiler and kernel cache (:mod:`.compiler`), CasADi
(:mod:`.casadi`) and the C time loop (:mod:`.c`)."""
