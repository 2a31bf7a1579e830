"""The batched, differentiable torch renderer used in training (``renderer``, torch alone), and
its check against the Mitsuba reference (``check``, which loads Mitsuba when it runs)."""
