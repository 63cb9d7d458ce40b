"""Slow processes fed by accepted contact exposures and feeding back through gaps and friction
(Section "Slow feedback through shared mechanical channels"; appendix "Slow-process models and
feedback protocols"): exposure windows, thermal network, lubrication, wear, fatigue, the
linearized coupling path, and the orchestrator that alternates mechanical windows and slow
updates. One module per process; import from the modules."""
