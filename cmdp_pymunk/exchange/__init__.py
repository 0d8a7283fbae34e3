"""Schedules in the formats planning tools open: the simulated schedule as MS Project XML
(``mspdi``). The CSV table is ``cmdp_pymunk.schedule``'s, the 4D IFC
``cmdp_pymunk.cases.ifc_export``'s."""
