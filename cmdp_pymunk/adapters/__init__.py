"""The RL adapters over the engine: the PettingZoo env (``env``), its registered variants
(``registry``), the global state for centralized critics (``global_state``) and the stage-2
decision loop with its Gymnasium env (``stage2``). The simulation imports none of them."""
