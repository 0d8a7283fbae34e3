"""Searches over whole floors on paired seeds: the GA's task priorities (``genetic``) and
the CMA-ES rule search (``rule``). Their results are evaluators in ``agents``."""
