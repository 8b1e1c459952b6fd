"""A test stand-in for move_base (not packaged in Debian here): a MoveBaseAction server in the
robot's namespace that drives the simulated robot straight to each goal from its ground truth
(no map, no obstacles; graph edges are free lines on the test maps). Only for the agent's
move_base client tests; run as `python move_base_mock.py __ns:=tb3_0`. Prints one line per goal.
"""

import math
import sys

import actionlib
import rospy
from geometry_msgs.msg import Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseFeedback
from nav_msgs.msg import Odometry

SPEED = 0.22  # [m/s] Burger
TURN = 2.84  # [rad/s]
REACHED_M = 0.03  # [m] inside the lab goal tolerance (0.05 m)


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class MockMoveBase:
    def __init__(self):
        self.pose = None
        rospy.Subscriber("base_pose_ground_truth", Odometry, self.on_pose, queue_size=1)
        self.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.server = actionlib.SimpleActionServer("move_base", MoveBaseAction, self.execute,
                                                   auto_start=False)
        self.server.start()
        self.goals = 0

    def on_pose(self, msg):
        p = msg.pose.pose
        self.pose = (p.position.x, p.position.y, yaw_of(p.orientation))

    def execute(self, goal):
        target = goal.target_pose.pose.position
        self.goals += 1
        print(f"GOAL {self.goals} {goal.target_pose.header.frame_id} {target.x:.3f} "
              f"{target.y:.3f}", flush=True)
        rate = rospy.Rate(20)
        fb = MoveBaseFeedback()
        while not rospy.is_shutdown():
            if self.server.is_preempt_requested():
                self.cmd.publish(Twist())
                self.server.set_preempted()
                return
            if self.pose is not None:
                x, y, th = self.pose
                dx, dy = target.x - x, target.y - y
                d = math.hypot(dx, dy)
                if d <= REACHED_M:
                    self.cmd.publish(Twist())
                    self.server.set_succeeded()
                    return
                err = (math.atan2(dy, dx) - th + math.pi) % (2 * math.pi) - math.pi
                cmd = Twist()
                cmd.angular.z = max(-TURN, min(TURN, 3.0 * err))
                # Turn in place unless nearly aligned (no orbiting around the goal).
                if abs(err) < (0.5 if d > 0.3 else 0.15):
                    cmd.linear.x = min(SPEED, 1.5 * d) * math.cos(err)
                self.cmd.publish(cmd)
                fb.base_position.pose.position.x, fb.base_position.pose.position.y = x, y
                self.server.publish_feedback(fb)
            rate.sleep()


if __name__ == "__main__":
    rospy.init_node("move_base", argv=sys.argv)
    MockMoveBase()
    rospy.spin()
