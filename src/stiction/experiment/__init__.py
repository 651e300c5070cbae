"""Psychophysics experiments on the real daemon: study files, sessions, data, a simulated observer.

See docs/experiments.md. `stiction experiment run` runs a study with a
person at a real device; `stiction experiment simulate` runs it headless with
simulated participants through the same daemon and the same session logic.
"""
