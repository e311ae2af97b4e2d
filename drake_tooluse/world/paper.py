"""The paper's task figures the project takes over (Kothavale & Boddepalli, arXiv 2510.26551).

Plain constants, no imports: the command line reads them for its defaults at start-up.
"""

# The paper's two tools (m): the short one is the demo's default, the long one the training's.
PAPER_TOOL_LENGTHS = (0.125, 0.175)
# Success when d(x, x*) + d(x, y) is at or below this (m): box to goal plus tool tip to box.
SUCCESS_DISTANCE = 0.05
# The demo hands the robot the short tool: the shipped policies trained with the long one.
DEMO_TOOL_LENGTH = PAPER_TOOL_LENGTHS[0]
