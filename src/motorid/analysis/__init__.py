"""Analyses built on identified models.

Validation on other inputs (:mod:`.validation`) and the paper's sensitivity tables over record
length and sample interval (:mod:`.sweep`).
"""
