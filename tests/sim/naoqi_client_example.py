"""A plain NAOqi client, written the way NAOqi's documentation writes them.

It knows nothing about Prezence: it runs unchanged against a real NAO or the virtual one.

    python naoqi_client_example.py --qi-url=tcp://127.0.0.1:9559
"""

from __future__ import annotations

import sys
import time

import qi


def main(session: qi.Session) -> None:
    """Wake up, turn the head (reactive, then timed), say a sentence."""
    motion = session.service("ALMotion")
    tts = session.service("ALTextToSpeech")

    motion.wakeUp()

    # Reactive control: setAngles returns at once; the joint gets there at 20 % of its max speed.
    motion.setAngles("HeadYaw", 0.3, 0.2)
    time.sleep(1.0)
    print("setAngles HeadYaw:", motion.getAngles("HeadYaw", True)[0])

    # Timed control: angleInterpolation blocks until the last key time.
    names = ["HeadYaw", "HeadPitch"]
    angle_lists = [[0.5, 0.0], [-0.2, 0.1]]
    time_lists = [[1.0, 2.0], [1.0, 2.0]]
    motion.angleInterpolation(names, angle_lists, time_lists, True)
    yaw, pitch = motion.getAngles(names, True)
    print("angleInterpolation HeadYaw:", yaw)
    print("angleInterpolation HeadPitch:", pitch)

    tts.say("Hello, I am NAO.")
    print("said: Hello, I am NAO.")


if __name__ == "__main__":
    app = qi.Application(sys.argv)  # reads --qi-url
    try:
        app.start()
    except RuntimeError:
        print("Can't connect to NAOqi at " + app.url + ". Please check the --qi-url argument.")
        sys.exit(1)
    main(app.session)
