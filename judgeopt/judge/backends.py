"""The names of the ways the judge is evaluated inside CasADi (judge.casadi_fn builds them), in a
module that imports nothing heavy: the command line lists them in its options at start-up."""

BACKENDS = ("native", "compiled", "torch", "torch32", "l4casadi", "l4casadi32")
#: the backends that need the network as a CasADi MX graph (Arch.native_logit)
GRAPH_BACKENDS = ("native", "compiled")
#: "auto" is a rule, not one backend (casadi_fn.choose_backend): for a noise-tolerant use (the direct solve's
#: judge as a constraint) l4casadi32 where l4casadi is installed and the architecture is in
#: AUTO_L4CASADI32, else the torch32 callback; otherwise l4casadi (float64) where installed, else native
DEFAULT_BACKEND = "auto"
