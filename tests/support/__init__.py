"""Support code of the tests and benchmarks that is not part of any shipped package.

``tests`` itself has no ``__init__`` (a namespace package found through the repository
root on ``sys.path``, pytest's ``pythonpath = ["."]``), so ``tests.support`` shadows no
installed module: import it as ``from tests.support.import_graph import ...``.
"""
