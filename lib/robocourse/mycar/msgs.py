"""mycar_msgs: the seed's service and action types (SetLed, NavigateToPose)."""

from robocourse.msgs import action, geometry_msgs, service  # noqa: F401  (PoseStamped for the action)

SetLed = service("mycar_msgs/srv/SetLed", """
int32 led_id
bool state
---
bool success
""")

NavigateToPose = action("mycar_msgs/action/NavigateToPose", """
geometry_msgs/PoseStamped target_pose
---
bool success
string message
float64 position_error       # m, goal to the pose odometry believes (what success is judged by)
float64 true_position_error  # m, goal to the true pose from /ground_truth (NaN if none was received)
---
float32 percent_complete
""")
