"""The calibration: one robot and a list of measurement sets, prepared, solved and scored."""
