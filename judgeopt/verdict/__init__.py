"""What judgeopt says about a plan: the p it stands behind and the word for it (rules), calibrated
on replayed outcomes (calibration), with the risk held-out outcomes put behind "likely" (risk), for
a fresh result or a stored row (rows).

It reads results' numbers and the planners' setting ids (strings), never the planners themselves,
so the planners' results can carry their verdict; what re-plans (suggestions) is in judgeopt.session.
"""
