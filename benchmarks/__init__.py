"""The benchmarks of roughfriction: FEM speed, memory and error, the stress matrix, the time
profile, the theory's timings, the zone-coverage study, the tamaas peer of the contact tests and
the generated tables of the docs.

Run from a checkout of the repository (``python -m benchmarks COMMAND ...``, the ``make bench*``
and ``make docs`` targets); not installed by ``pip install``. The benchmarks import
roughfriction; roughfriction never imports them (``tests/test_benchmark.py`` checks it).
"""
