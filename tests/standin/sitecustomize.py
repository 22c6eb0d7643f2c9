"""Put the exact-version stand-in driver (tests/exact_driver.py) behind glcontext's EGL backend in
every Python process started with this folder and tests/ on PYTHONPATH, e.g. the whole GPU check:

    PYTHONPATH=tests/standin:tests bash .ci/gpu-check OUTDIR --quick

(docs/platforms.md, "What was verified where")."""

import exact_driver

exact_driver.install()
