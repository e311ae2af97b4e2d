"""The experiments' option names, without Drake: the command line checks them before it imports
the modules that use them (`experiments.transfer`, `experiments.trajectory_extraction`)."""

MODES = ("closed-loop", "open-loop")  # a transfer run: the policy in the loop, or a replay
ALIGNMENTS = ("start", "contact")  # averaging episodes from their start or the first touch
# What a recorded trajectory holds at each step: where the tip got (the paper's: with Fetch's
# mocap it is where it was commanded), or the tip pose the step commanded (the IK's joint
# targets). Baxter's arm lags its command by ~2 cm at full speed, so a replay of where the tip
# got commands a slower push that trails the recorded one.
RECORDS = ("achieved", "commanded")
# How the open-loop transfer makes its trajectory of the policy's episodes: the paper's per-step
# mean of where the tip got, replayed as it is; or that of the commanded poses, of each episode
# in its box's frame, the tool tilted into a line contact, and replayed at the box start the
# hand camera measures (`experiments.line_contact`).
EXTRACTIONS = ("line-contact", "mean-achieved")
# What each takes by default for the recording (RECORDS).
EXTRACTION_RECORDS = {"line-contact": "commanded", "mean-achieved": "achieved"}
# Randomization draws of the nominal simulation over which a line-contact trajectory is moved
# across the push to where it pushes best (`experiments.line_contact.calibrated`); 0: not.
CALIBRATION_DRAWS = 16
MAX_CALIBRATION_DRAWS = 1000  # the most any command takes
