"""The controller's reference inputs: joint trajectories, force references, task targets and wrenches.

ReferenceInputs turns each message into a call on the ControllerCore of a ControllerSession
(robot_control.ros.controller_session), or into a rejection with its reason; a trajectory's outcome
(robot_control.core.tolerances) is logged and put on /diagnostics once.
"""
from robot_control.ros import conversions
from robot_control.validation import ArgumentError


class ReferenceInputs:
    """The reference callbacks of `session` (its core, time line, counters, log and rejections)."""

    def __init__(self, session):
        self._s = session
        self._goal_seen = None

    def on_trajectory(self, msg):
        """A joint trajectory, as joint_trajectory_controller takes it (robot_control.core.references);
        an empty one cancels the motion and holds the current position."""
        try:
            goal = conversions.trajectory_goal(msg, self._s._joints, self._s.allow_partial)
            if not self._s.controller.running:
                raise ValueError('controller not running (no joint_states yet, or watchdog tripped)')
            if goal.empty:
                self._s.core.hold_position()
                self._s.counters.trajectories_accepted += 1
                self._s.log.info('empty trajectory: motion cancelled, holding the current position')
                return
            t0 = self._s.core.set_trajectory(goal.times, goal.positions, goal.velocities, goal.accelerations,
                                           t_start=self._s.timeline.time_of(goal.stamp_ns))
        except ValueError as exc:
            self._s.reject('joint_trajectory', exc)
            return
        self._s.counters.trajectories_accepted += 1
        self._s.log.info(f'trajectory accepted: {goal.times.shape[0]} points over {goal.times[-1]:g} s '
                               f'from t = {t0:.6f} s')

    def report_goal(self):
        """Log a trajectory's outcome once (robot_control.core.tolerances) and put it on /diagnostics."""
        goal = self._s.core.goal
        seen = (goal.goals, goal.outcome)
        if seen == self._goal_seen or not goal.outcome:
            return
        self._goal_seen = seen
        log = self._s.log
        {'succeeded': log.info, 'cancelled': log.info, 'missed': log.warning, 'path': log.error}[goal.outcome](
            f'trajectory {goal.outcome}: {goal.reason}')
        self._s.publish_diagnostics()

    def on_wrench_reference(self, msg):
        """A force reference: at once (header.stamp zero or not ahead of the last state), or pending
        until the first state stamped at or after header.stamp (one pending; a new one replaces it)."""
        axes = self._s.core.config.control_law.force_task.force_axes
        try:
            if not axes:
                raise ArgumentError('force_axes', 'none configured (parameter force_axes)')
            f_d = conversions.wrench_force(msg, axes)
            stamp_ns = conversions.stamp_to_ns(msg.header.stamp)
            ahead = self._s.timeline.ahead(stamp_ns)
            self._s.core.set_force_reference(f_d, t_start=self._s.timeline.time_of(stamp_ns) if ahead else None)
        except ValueError as exc:
            self._s.reject('wrench_reference', exc)
            return
        when = f' from t = {self._s.timeline.time_of(stamp_ns):.6f} s' if ahead else ''
        self._s.log.info(f'force reference {dict(zip(axes, f_d.tolist()))} N{when}')

    def on_target_pose(self, msg):
        """A task-space target for the laws that track one (impedance; hybrid's motion axes): at once, or
        from header.stamp when that lies ahead of the last state."""
        cfg = self._s.core.config
        try:
            if cfg.control_law.tracks != 'task':
                raise ValueError(f'law {cfg.law} follows no task-space target (impedance and hybrid do)')
            if not self._s.controller.running:
                raise ValueError('controller not running (no joint_states yet, or watchdog tripped)')
            position, quaternion = conversions.pose_target(msg, cfg.model.base_frame)
            stamp_ns = conversions.stamp_to_ns(msg.header.stamp)
            ahead = self._s.timeline.ahead(stamp_ns)
            self._s.core.set_target_pose(cfg.model.task_position(position, quaternion),
                                       t_start=self._s.timeline.time_of(stamp_ns) if ahead else None)
        except ValueError as exc:
            self._s.reject('target_pose', exc)
            return
        self._s.counters.target_poses_accepted += 1

    def on_target_wrench(self, msg):
        """A feed-forward wrench on the task axes (impedance), the robot on its environment, in the model's
        base frame (header.frame_id that frame or '')."""
        model = self._s.core.config.model
        try:
            if not model.task_dim:
                raise ValueError('the model has no task space (set tip)')
            conversions.check_base_frame(msg, model.base_frame)
            self._s.core.set_target_wrench(conversions.wrench_force(msg, model.task_axes))
        except ValueError as exc:
            self._s.reject('target_wrench', exc)
            return
        self._s.counters.target_wrenches_accepted += 1
