"""One planning request from start to verdict (solve): the planners run, their results judged
(judgeopt.verdict), and, where the plan to run is not likely, the relaxation that would make it so
(suggest); how the report reads to a person (views). Above the planners, as it re-plans."""
