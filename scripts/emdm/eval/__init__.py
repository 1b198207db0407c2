"""Evaluation: metrics on evaluator embeddings (``metrics``), physical plausibility of joint
motions (``plausibility``), the trained evaluators (``evaluators``: text–motion matcher and action
classifier), running evaluations into JSON (``evaluate``) and the RESULTS.md generator (``report``)."""
