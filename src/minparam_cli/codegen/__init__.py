"""Code generation: the base regressor (and an identified model's inverse dynamics) as C99, NumPy or
CasADi code, from one straight-line program recorded by running the Newton–Euler regressor on
tracer values (trace.py → programs.py → functions.generate_code → emit_c / emit_python)."""
