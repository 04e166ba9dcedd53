"""The virtual NAO: a simulated robot that speaks the NAOqi protocol (``qi``) on loopback.

A client (``NaoqiBackend``, or any script written for a real NAO) connects with
``qi.Session().connect("tcp://127.0.0.1:PORT")`` and uses ``session.service("ALMotion")`` and
friends exactly as on the robot. Behind the services is the PyBullet NAO (:class:`sim.nao.NaoSim`)
or, with ``model="kinematic"``, :class:`KinematicNao` (velocity-capped integration, no physics).

Semantics follow NAOqi's documentation (``reference/naoqi_api.md``):

- *Blocking* calls (``angleInterpolation*``, ``goToPosture``, ``say``, ``fadeRGB``…) block the
  caller, not the service: the method returns a ``qi.Future`` from a ``qi.Promise`` that the
  simulation clock completes, so ``getAngles``/``setAngles`` still answer during a gesture.
  Services stay single-threaded (qi's default), so a burst of ``setAngles`` applies in order.
- ``setAngles`` retargets; speed is ``fractionMaxSpeed × the joint's velocity limit``; targets
  are clipped to the position limits; chain names (``Head``, ``LArm``, ``Body``…) expand; names,
  angles and times may be scalars or lists.
- ``angleInterpolation`` keyframes get the same clipping as ``setAngles`` targets (joint ranges,
  the head anti-collision table at the HeadYaw planned for that key time, one hip motor). Keys too
  close together for a joint's velocity limit are spread out, never followed late: the motion is
  slowed down to the limit, the call returns when it is done, and one warning per call names the
  joint, the speed asked and the limit (:func:`plan_keyframes`).
- A blocking motion on joints that a running one holds waits until that one ends or is killed
  (NAOqi's motion tasks and resources); ``say`` sentences queue behind each other.
- Bad input raises; the client sees NAOqi's kind of error, a ``RuntimeError`` with a text.
- Commands to joints whose stiffness is 0 are accepted and ignored, as on the robot. The virtual
  NAO starts awake (stiffness 1).
- ``ALTextToSpeech.say`` logs each phrase at INFO on the ``sim.virtual_nao.speech`` logger (no
  audio is produced), and the speech log records its start and end.

Time: a server must run in real time, because its clients do. So, unlike everything else in
Prezence (where the caller's clock drives the physics), ONE loop thread steps the model to the
wall clock at ``rate_hz`` and completes the promises whose time has come. It is the only
free-running loop in the project, on purpose. ``VirtualNao.start(realtime=False)`` leaves the
clock to the caller (:meth:`VirtualNao.tick`), for tests.

Run it with ``python -m sim.virtual_nao --port 0`` (prints ``listening on tcp://127.0.0.1:PORT``)
or ``prezence sim serve``.

Modules, one per concern (their public names are re-exported here): :mod:`.robot` (body names, the
model, :class:`VirtualNao` and its task scheduler), :mod:`.planning` (``angleInterpolation``
keyframes), :mod:`.services` (ALMotion, ALTextToSpeech, ALLeds, ALRobotPosture, ALMemory,
ALAutonomousLife) and
:mod:`.server` (:func:`serve`, :func:`spawn`, :func:`stop_spawned`, the command line).
"""

from sim.virtual_nao.planning import SPEED_TOL, KeyframePlan, min_segment_time, plan_keyframes
from sim.virtual_nao.robot import (
    BODY,
    GROUPS,
    LED_GROUPS,
    KinematicNao,
    Model,
    VirtualNao,
    body_specs,
    make_model,
)
from sim.virtual_nao.server import (
    VirtualNaoServer,
    build_parser,
    main,
    serve,
    spawn,
    stop_spawned,
)
from sim.virtual_nao.services import (
    LED_COLORS,
    POSTURES,
    SPEECH_LOGGER,
    ALAutonomousLife,
    ALLeds,
    ALMemory,
    ALMotion,
    ALRobotPosture,
    ALTextToSpeech,
)

__all__ = [
    "SPEECH_LOGGER",
    "BODY",
    "GROUPS",
    "body_specs",
    "POSTURES",
    "LED_GROUPS",
    "LED_COLORS",
    "Model",
    "KinematicNao",
    "make_model",
    "VirtualNao",
    "SPEED_TOL",
    "KeyframePlan",
    "min_segment_time",
    "plan_keyframes",
    "ALMotion",
    "ALTextToSpeech",
    "ALLeds",
    "ALRobotPosture",
    "ALMemory",
    "ALAutonomousLife",
    "VirtualNaoServer",
    "serve",
    "spawn",
    "stop_spawned",
    "build_parser",
    "main",
]
