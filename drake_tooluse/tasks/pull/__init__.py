"""The pull task: the robot reaches over a cube that lies beyond its bare gripper's reach with
a hook, hooks it from behind and pulls it to a goal near itself. Every episode may hold a
different hook (`robot.tool.HookTool`); the robot knows its hook's geometry.

- `hook`: how the hook is held (a rake) and the hooks drawn per episode;
- `metrics`: the task's truth read from the world plant (distances, contacts, success) and
  its reward;
- `observation`: what the policy sees (`ToolPullObservation`);
- `diagram`: the task wired into a builder (`add_pull_task`);
- `env`: the Gymnasium env `drake_tooluse/ToolPull-v1` on `pydrake.gym.DrakeGymEnv`;
  `registration` registers its id (no Drake imported); `scripted`: a scripted reference pull.

Its scenario is the top-level `diagrams/pull.yaml`.
"""
