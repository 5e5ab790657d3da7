"""attachment: the safe-home-base cycle (SPEC 5) - anxiety, looking back, running to hug.

For each character with an :class:`~twig_ecs.components.Attachment`: anxiety grows
with the distance beyond ``safe_distance`` from the caregiver and with time away, and
fades near the caregiver. Past ``look_back_at`` the child now and then stops to look
back at the caregiver (a glance of ``GLANCE`` seconds); past ``return_at`` it runs to
the caregiver and hugs it (a hug goal, with the hands it has free); the hug soothes:
anxiety drops to zero and play resumes.
"""

from __future__ import annotations

from dataclasses import dataclass

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.character import CharacterHandle
from twig_ecs.components import Attachment, Character
from twig_ecs.steering import ground_distance
from twig_ecs.step import StepContext
from twig_ecs.systems.behaviours.hug import ARMS_NOT_ROUND


@dataclass(slots=True)
class Glance:
    """An attached child's looks back at its caregiver (systems/behaviours/attachment.py)."""

    until: float = -1.0  # s the current glance ends (in the past: not glancing)
    last: float = -1e9  # s the last glance began


GLANCE = 1.0  # s a look back lasts
GLANCE_EVERY = 5.0  # s at least between look-backs
LOOK_BACK = 0.7  # activation of a glance: above play
RUN_HOME = 1.0  # activation of running back: above play and fights, below pain
FINISH_MARGIN = 0.15  # anxiety past return_at that an action about to end still waits for (about
# 1.5 s at 10 m from the caregiver: seed 0's 1.05 m child, lined up behind the ball, ran home 0.5 s
# before its kick)


@dataclass
class Soothe:
    """A run-home hug's ``on_end``: a hug that reached the caregiver calms the child - also
    one whose arms did not get round in time: the wrap begins at the caregiver's side, and
    being there is what soothes (seed 0 once ended a 3 s wrap pressed to the parent, doll in
    hand, and went back to play still anxious).

    A small class rather than a closure, so a snapshot of the scene can keep it.
    """

    attachment: Attachment

    def __call__(self, done: Goal) -> None:
        if done.status == "done" or done.reason == ARMS_NOT_ROUND:
            self.attachment.anxiety, self.attachment.hugs = 0.0, self.attachment.hugs + 1


@register
class AttachmentBehavior(Behavior):
    """Keeps a child tied to its caregiver: glances back, runs back for a hug."""

    name = "attachment"
    component = Attachment

    def run(self, ctx: StepContext) -> None:
        """Update every attached child's anxiety, then propose."""
        dt = ctx.dt
        scene = self.scene
        for entity, (_, attachment) in ctx.world.get_components(Character, Attachment):
            me = scene.character_handle(entity)
            caregiver = self._caregiver(attachment)
            if caregiver is None:
                continue
            home = caregiver.position
            distance = ground_distance(me.position, home)
            if distance > attachment.safe_distance:
                attachment.anxiety += dt * (attachment.per_metre * (distance - attachment.safe_distance)
                                            + attachment.per_second)  # fmt: skip
            else:
                attachment.anxiety -= dt * attachment.fade
            attachment.anxiety = min(1.0, max(0.0, attachment.anxiety))
        super().run(ctx)

    def _caregiver(self, attachment: Attachment) -> CharacterHandle | None:
        """The caregiver's handle; None while there is no character of that name (removed, or
        its name reused by a ball: a child cannot glance at a ball's head nor hug it)."""
        try:
            handle = self.scene.entity(attachment.caregiver)
        except KeyError:
            return None
        return handle if isinstance(handle, CharacterHandle) else None

    def activation(self, character, mind: Mind, goal) -> float:
        """Run home when anxious enough, glance back when somewhat anxious."""
        attachment = self.settings(character)
        if self._caregiver(attachment) is None:
            return 0.0
        if any(g.behavior == "hug" for g in mind.goals):
            return 0.0  # already on its way home
        now = self.scene.time
        if attachment.anxiety >= attachment.return_at:
            if now < attachment.finishing_until and attachment.anxiety < attachment.return_at + FINISH_MARGIN:
                return 0.0  # it finishes what it is about to do first (a kick, lined up)
            return RUN_HOME
        glance = self.world.try_component(character.entity, Glance) or Glance()
        if glance.until > now:
            return LOOK_BACK
        if attachment.anxiety >= attachment.look_back_at and now - glance.last > GLANCE_EVERY:
            return LOOK_BACK
        return 0.0

    def start(self, character, goal: Goal | None) -> None:
        """A glance begins (unless this is the run home)."""
        attachment = self.settings(character)
        if attachment.anxiety < attachment.return_at:
            now = self.scene.time
            self.world.add_component(character.entity, Glance(until=now + GLANCE, last=now))
            attachment.look_backs += 1

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Glance: stand and look at the caregiver. Anxious: queue a hug and go."""
        attachment = self.settings(character)
        if attachment.anxiety >= attachment.return_at:
            character.hug(attachment.caregiver, duration=1.5, run=True, on_end=Soothe(attachment))
            self._end_glance(character)
            return
        character.stop()
        character.look_at(attachment.caregiver, node="head")

    def stop(self, character, goal) -> None:
        """The glance is over."""
        self._end_glance(character)

    @staticmethod
    def _end_glance(character) -> None:
        glance = character.world.try_component(character.entity, Glance)
        if glance is not None:
            glance.until = -1.0
