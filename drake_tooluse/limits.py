"""The ranges of the counts the project takes, each declared once.

A command's option and the library function that takes the same value check it against the same
name here (the command first, naming its option; the library again, for callers from Python).
Nothing is imported, so a command checks its options before it imports Drake or torch.
"""

SEED_MAX = 2**32 - 1  # Drake's RandomGenerator and numpy's legacy seeding take 32 bits
MAX_TIMESTEPS = 10**10  # env steps of one training (the paper's budget is 1.25e6)
MAX_EPISODES = 100_000  # episodes of one evaluation, extraction or distillation round
MAX_N_ENVS = 64  # parallel envs of one training
MAX_RUNS = 10_000  # transfer runs per tool
MAX_SEEDS = 1000  # seeds of one study cell
MAX_PARALLEL = 64  # study runs at a time
MAX_TRAJECTORIES = 1000  # generated trajectories a study report draws
MAX_CALIBRATION_DRAWS = 1000  # randomized replays of an open-loop calibration
MAX_ROLLOUTS = 20  # rollouts per tool of a tool choice
MAX_WORKERS = 64  # worker processes of a tool choice's rollouts
MAX_ROUNDS = 1000  # distillation rounds
MAX_EPOCHS = 10_000  # epochs of a distillation round
MAX_BATCH_SIZE = 1_000_000  # samples of a distillation batch
MAX_FRAME_STEP = 100  # control steps between two frames of a video
MAX_COLORS = 256  # a GIF's palette holds at most this many
MAX_FAILURES = 100  # failed runs a sweep tolerates
MAX_CELLS = 10_000  # runs in one sweep grid: past this Tune's own bookkeeping takes minutes
MAX_CPUS = 4096  # CPUs a sweep asks Ray for
MAX_SMOOTHING_WINDOW = 999  # steps of the trajectory extraction's moving average
MAX_TOOL_PAIRS = 100  # tool pairs a retooling benchmark compares
MAX_BENCHMARK_PERIODS = 100_000  # control periods one benchmark episode simulates
MAX_NOISE_SIGMA = 50.0  # camera noise, grey levels: past this the markers drown in the noise

# The command line's count options, each with its range (lowest, highest): `cli.common.count_arg`
# checks an option through it, and the help of every option named here shows it.
OPTION_RANGES = {
    "--episodes": (1, MAX_EPISODES),
    "--n-eval-episodes": (1, MAX_EPISODES),
    "--timesteps": (1, MAX_TIMESTEPS),
    "--eval-freq": (1, MAX_TIMESTEPS),
    "--save-freq": (1, MAX_TIMESTEPS),
    "--n-envs": (1, MAX_N_ENVS),
    "--runs": (1, MAX_RUNS),
    "--parallel": (1, MAX_PARALLEL),
    "--trajectories": (1, MAX_TRAJECTORIES),
    "--calibration-draws": (0, MAX_CALIBRATION_DRAWS),
    "--rollouts": (1, MAX_ROLLOUTS),
    "--workers": (1, MAX_WORKERS),
    "--rounds": (1, MAX_ROUNDS),
    "--epochs": (0, MAX_EPOCHS),
    "--every": (1, MAX_FRAME_STEP),
    "--colors": (2, MAX_COLORS),
    "--max-failures": (0, MAX_FAILURES),
    "--num-cpus": (1, MAX_CPUS),
    "--window": (1, MAX_SMOOTHING_WINDOW),
}
