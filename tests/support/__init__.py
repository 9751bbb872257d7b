"""Support code of the tests and benchmarks that is not part of any shipped package:
`ekf_reference` (a plain NumPy EKF step the engine is checked against) and `ekf_examples`
(a toy model with the navigator's dimensions).

``tests`` itself has no ``__init__`` (a namespace package found through the repository
root on ``sys.path``, pytest's ``pythonpath = ["."]``), so ``tests.support`` shadows no
installed module: import it as ``from tests.support.ekf_reference import ...``. The import
graph of the repository is checked by ``tests/test_import_graph.py``.
"""
