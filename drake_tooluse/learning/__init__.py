"""Training and evaluation with stable-baselines3: the policy-directory format, configs, sweeps."""
