"""Speed benchmarks, each figure a CPU-time ratio taken interleaved with its baseline.

- :mod:`~tensim.benchmarks.engine`: tensim's loop against MuJoCo alone on the same inputs
  (``tensim bench``);
- :mod:`~tensim.benchmarks.batch`: many trials per call against ``mujoco.rollout``
  (``tensim bench --batch N``);
- :mod:`~tensim.benchmarks.learning`: CMA-ES evaluations per second (``tensim bench
  --learning``);
- :mod:`~tensim.benchmarks.process`: whole commands as processes, with and without figures
  (``tensim bench --process``);
- :mod:`~tensim.benchmarks.warp`: batches of worlds on MuJoCo Warp beside the CPU engine
  (``tensim bench --backend warp``);
- :mod:`~tensim.benchmarks._machine`: how busy the machine was, and a busy mode.

Nothing in the library imports this package; it imports whatever it measures.
"""
