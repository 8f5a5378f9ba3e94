"""Each state is answered with the wrench of its own tick.

The simulator publishes a tick's wrench, then its state, both stamped t_k. They reach the controller
through two DDS readers, and under load the state can come first. While the wrench stream is
paired with the states (the newest wrench is stamped like the previous state), a state whose
wrench has not come yet is held until it comes, or until the node's one-shot timer says the wait
is over; every answer then uses the force of its own tick and lockstep runs repeat bit for bit.
The first state waits too when the node knows a wrench publisher is there. An unstamped or
unpaired wrench stream is not waited for after that. The held state coming again (a lockstep
simulator re-publishes a state it has no answer for) keeps waiting: a wait without a limit (the
node's wrench_wait 0, for lockstep, where the wrench is published before its state) ends only
with the wrench. Stamps are integer ns.
"""


class WrenchPairing:
    """Holds at most one state (any payload) until the wrench stamped like it has come."""

    def __init__(self):
        self.wrench_ns = None       # stamp of the newest wrench
        self.last_state_ns = None   # stamp of the last state released for an answer
        self.held = None            # (stamp_ns, payload) waiting for its wrench

    def state(self, stamp_ns, payload, publisher=False):
        """A new state: the payloads to answer now, in order (a state still held goes first; the new
        one is held, and not in the list, when the streams are paired and its wrench is still due; the
        held state again: still held, []). publisher: a wrench publisher exists (only asked for the first
        state)."""
        if self.held is not None and self.held[0] == stamp_ns:
            return []
        out = self.release()
        last = self.last_state_ns
        if last is None:
            paired = publisher
        else:
            paired = self.wrench_ns == last and stamp_ns > last
        if paired and (self.wrench_ns is None or self.wrench_ns < stamp_ns):
            self.held = (stamp_ns, payload)
            return out
        self.last_state_ns = stamp_ns
        return out + [payload]

    def wrench(self, stamp_ns):
        """A wrench came (the node has taken its force): the held state if this was its wrench, else []."""
        self.wrench_ns = stamp_ns
        if self.held is not None and stamp_ns >= self.held[0]:
            return self.release()
        return []

    def release(self):
        """The held state, if any, to answer now (the wait is over): [] or [payload]."""
        if self.held is None:
            return []
        (stamp_ns, payload), self.held = self.held, None
        self.last_state_ns = stamp_ns
        return [payload]
