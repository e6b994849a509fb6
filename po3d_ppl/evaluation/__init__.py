"""Evaluation: accuracy tables against the baselines, difficulty analysis and calibration studies.

It may use every stage (it measures them against each other); no stage imports it.
"""
