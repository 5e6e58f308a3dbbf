"""judgeopt as a service a robot stack calls (`judgeopt serve`): models loaded once per worker
process, plans answered over HTTP as the object `judgeopt solve --json` prints.

One job per module: `config` (the settings, each default once; who may bind where), `schema` (the
request and answer on the wire, pydantic: the OpenAPI schema comes from them), `request` (a request
turned into a problem, checked as the command line checks it), `worker` (one planning process),
`pool` (the workers supervised: a bounded queue, deadlines, a dead worker replaced), `metrics`
(Prometheus), `app` (the ASGI app: routes, limits, the token, errors as one line), `server`
(uvicorn, SIGTERM) and `client` (`judgeopt.Client`, standard library only).

Only `client` is imported by `import judgeopt` paths; the rest needs the `serve` extra
(pip install 'judgeopt[serve]').
"""
