"""Studies that run many scenarios: accuracy over seeds, error budget, speed benchmark, robustness."""
