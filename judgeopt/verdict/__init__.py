"""What judgeopt says about a plan: the risk behind its verdict (judgeopt.verdict.risk).

Depends on nothing else of judgeopt, so the planners' results can read it.
"""
