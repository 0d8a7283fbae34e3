"""Research tools: what a teacher's labels are worth and how to distil them (``distill``,
``label_noise``; ``python -m training.research.distill``). Not commands of the package: they
build on the commands' libraries and nothing imports them."""
