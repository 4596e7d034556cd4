"""mutual: the algorithms of the thesis "Towards Mutual Understanding between
Mortals and Machines in Motion for Safety", one module per idea."""

__version__ = "0.1.0"
