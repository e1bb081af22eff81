"""Analyses built on identified models: validation on other inputs (:mod:`.validation`) and the
paper's sensitivity tables over record length and sample interval (:mod:`.sweep`)."""
