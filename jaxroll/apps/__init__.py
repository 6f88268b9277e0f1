"""Applications on top of the library: the ``jaxroll`` command line (:mod:`~jaxroll.apps.cli`),
the reproduction of the paper's tables and figures (:mod:`~jaxroll.apps.reproduce`) and plots
(:mod:`~jaxroll.apps.plot`)."""
