"""Benchmarks: ``python -m penalty_env.bench {core,env,accuracy,stability,energy,soak,figures}``."""
