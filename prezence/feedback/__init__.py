"""Feedback: commands → gestures and phrases, timed against the NAO's joint limits."""
