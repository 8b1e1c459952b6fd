"""move_base backend of the agent: a MoveBaseAction client (actionlib) for tpuaf.navigation's
GoalNavigator. For users of turtlebot3_navigation; move_base itself is not packaged in Debian
here, so the tests drive it against a test action server (tests/ros/move_base_mock.py)."""

from __future__ import annotations

import math

import actionlib
import rospy
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal

from tpuaf.navigation import GoalClient

_FAILED = (GoalStatus.ABORTED, GoalStatus.REJECTED, GoalStatus.LOST)


class MoveBaseClient(GoalClient):
    """Sends goals (x, y, yaw in `frame`) to the action server `action` (relative name)."""

    def __init__(self, action: str = "move_base", frame: str = "map"):
        self.action = rospy.resolve_name(action)
        self.client = actionlib.SimpleActionClient(action, MoveBaseAction)
        self.frame = frame
        self._state = "idle"
        self._goal_id = 0
        self._warned = False

    def connected(self) -> bool:
        return self.client.wait_for_server(rospy.Duration(0.001))

    def send(self, x: float, y: float, yaw: float) -> None:
        if not self.connected() and not self._warned:
            self._warned = True
            rospy.logwarn(f"move_base action server {self.action} not connected (yet): goals "
                          "are sent anyway and fail after ~move_base_timeout without progress")
        goal = MoveBaseGoal()
        pose = goal.target_pose
        pose.header.frame_id = self.frame
        pose.header.stamp = rospy.Time.now()
        pose.pose.position.x, pose.pose.position.y = float(x), float(y)
        pose.pose.orientation.z, pose.pose.orientation.w = math.sin(0.5 * yaw), math.cos(0.5 * yaw)
        self._goal_id += 1
        gid = self._goal_id
        self._state = "active"
        self.client.send_goal(goal, done_cb=lambda status, _result: self._done(gid, status))

    def _done(self, gid: int, status: int) -> None:
        if gid != self._goal_id:
            return  # a goal we replaced
        if status == GoalStatus.SUCCEEDED:
            self._state = "succeeded"
        elif status in _FAILED:
            self._state = "failed"
        else:
            self._state = "idle"

    def cancel(self) -> None:
        self._goal_id += 1
        self._state = "idle"
        self.client.cancel_all_goals()

    def state(self) -> str:
        return self._state
