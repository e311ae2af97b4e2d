"""The push task: the robot pushes a box along the table to a goal with the tool it holds (the
paper's Env1, Env2 and Env3).

- `metrics`: the task's truth read from the world plant (distances, contacts, success) and the
  paper's rewards;
- `observation`: what the policy sees (`ToolPushObservation`);
- `diagram`: the task wired into a builder (`add_push_task`), a policy closed-loop in a diagram,
  runs of it and the open-loop replay of a tool-tip trajectory;
- `env`: the Gymnasium envs on `pydrake.gym.DrakeGymEnv`; `registration` registers their ids
  (no Drake imported); `scripted`: a scripted reference push.

Its scenarios are the top-level `diagrams/push*.yaml`.
"""
