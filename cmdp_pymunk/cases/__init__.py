"""Case input and output: the case data model (``model``), its loading (``load``) and checks
(``field_problems``, ``case_check``, ``time_checks``, ``lever_checks``, ``reach``), floor
plans and task recipes (``floorplan``), generated layouts (``generated``), a storey of an IFC
model as a case (``ifc_import``, from ``ifc_overlay``, ``ifc_model``, ``ifc_storey``,
``ifc_schedule`` and ``ifc_levels``) and a schedule as 4D IFC (``ifc_export``); beside them the
built-in cases as files. It imports nothing of the simulation."""
