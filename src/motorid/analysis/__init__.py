"""Analyses built on identified models.

Validation on other inputs (:mod:`.validation`), the paper's sensitivity tables over record
length and sample interval (:mod:`.sweep`) and the experiment advisor — how to record the next
capture, with each scope setting's predicted intervals (:mod:`.advice`).
"""
