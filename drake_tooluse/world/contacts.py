"""Which of the robot's bodies touch the box, read from the world plant's contact results: the
tool, or the robot itself (its gripper, its arm). The tasks' metrics read it every step."""

from __future__ import annotations

from drake_tooluse.world.scene import World


class BoxContacts:
    """Reads, from a contact results value of `world.plant`, whether the tool and whether any
    other body of the robot touch the box."""

    def __init__(self, world: World):
        plant = world.plant
        # Body indices as ints: comparing ints is cheaper than comparing pydrake's BodyIndex
        # objects, and this runs every control step.
        self._box = int(world.box.index())
        self._tool = int(world.tool.index()) if world.tool is not None else None
        self._robot = {int(i) for i in plant.GetBodyIndices(world.baxter)}
        self._robot.discard(self._tool)

    def touches(self, contacts) -> tuple[bool, bool]:
        """(the tool touches the box, another body of the robot touches it) in `contacts`, the
        plant's ContactResults."""
        tool_touch = robot_touch = False
        box, tool, robot = self._box, self._tool, self._robot
        info_at = contacts.point_pair_contact_info
        for i in range(contacts.num_point_pair_contacts()):
            info = info_at(i)
            a = int(info.bodyA_index())
            # Only the box touching the tool or the robot counts: where body A is none of them
            # (the table, under the box's corners, nearly every step), B is not read at all
            # (each read through pydrake costs more than the rest of the loop).
            if a == box:
                other = int(info.bodyB_index())
            elif (a == tool or a in robot) and int(info.bodyB_index()) == box:
                other = a
            else:
                continue
            tool_touch |= other == tool
            robot_touch |= other in robot
        return bool(tool_touch), bool(robot_touch)
