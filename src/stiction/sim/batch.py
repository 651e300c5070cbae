"""Placeholder replaced below."""


class BatchSim:
    pass
