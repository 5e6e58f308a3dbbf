"""judgeopt: plan contact-rich motions against a learned success judge."""
__version__ = "0.1.0"
