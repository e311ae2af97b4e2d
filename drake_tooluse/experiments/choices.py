"""The experiments' option names, without Drake: the command line checks them before it imports
the modules that use them (`experiments.transfer`, `experiments.trajectory`)."""

MODES = ("closed-loop", "open-loop")  # a transfer run: the policy in the loop, or a replay
ALIGNMENTS = ("start", "contact")  # averaging episodes from their start or the first touch
# What a recorded trajectory holds at each step: where the tip got (the paper's: with Fetch's
# mocap it is where it was commanded), or the tip pose the step commanded (the IK's joint
# targets). Baxter's arm lags its command by ~2 cm at full speed, so a replay of where the tip
# got commands a slower push that trails the recorded one.
RECORDS = ("achieved", "commanded")
