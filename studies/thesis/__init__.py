"""The thesis reproductions: one module per chapter (``covert`` ch. 3, ``cells`` ch. 4, ``shark``
ch. 5, ``herding`` ch. 6) with its tables, figures and built-in gap study, the fidelity studies,
the stealth front, the GA's readings and the reproduction report.

This package uses the study engine (instances, kinds, methods, runner, store, library, analysis)
and is never imported by it: the engine reads as one path, instance → kind → method → runner →
score → store, without the thesis in it. The command line and the benches import both.
"""

__all__: list[str] = []
