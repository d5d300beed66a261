#!/usr/bin/python3
"""Checks the manifests of deploy/k8s without a cluster.

    deploy/k8s/check.py            (Debian's python3; python3-yaml, python3-kubernetes optional)

1. every file of kustomization.yaml parses as YAML;
2. every object against the Kubernetes API models of python3-kubernetes (apt-get install
   python3-kubernetes): no unknown field, the right types, the required fields (skipped when
   the package is missing; the models are of its API version, 1.22 on bookworm);
3. the run holds together: the ConfigMap holds a config, the replay
   StatefulSet has run.shards replicas and the actor StatefulSet COINS_ACTORS, every Service
   selects the pods of one workload, COINS_DISCOVERY names the discovery Services, their ports
   and server indices, every ConfigMap and claim a pod uses is defined, every container runs
   coins-pod with a role.
Exits 1 when a check fails.
"""
import os
import re
import sys

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
ROLES = {"discovery", "replay", "learner", "orchestrator", "actors", "all"}

failures = []
passed = 0


def check(ok, what):
    global passed
    if ok:
        passed += 1
    else:
        failures.append(what)
        print("FAIL:", what)


def load():
    kust = yaml.safe_load(open(os.path.join(HERE, "kustomization.yaml")))
    objs = []
    for f in kust["resources"]:
        try:
            docs = [d for d in yaml.safe_load_all(open(os.path.join(HERE, f))) if d is not None]
            check(True, f)
        except yaml.YAMLError as e:
            check(False, f"{f}: not YAML: {e}")
            continue
        for d in docs:
            objs.append((f, d))
    return objs


# --- 2. the API models ---------------------------------------------------------------------------

def schema_check(objs):
    try:
        from kubernetes import client
    except ImportError:
        print("skipped: the API model check (no python3-kubernetes; /usr/bin/python3 has it from Debian)")
        return
    conf = client.Configuration()
    conf.client_side_validation = True

    def model(name):
        return getattr(client.models, name, None)

    def walk(value, typ, path, errors):
        m = re.fullmatch(r"list\[(.+)\]", typ)
        if m:
            if not isinstance(value, list):
                errors.append(f"{path}: expected a list")
                return
            for i, v in enumerate(value):
                walk(v, m.group(1), f"{path}[{i}]", errors)
            return
        m = re.fullmatch(r"dict\(str, (.+)\)", typ)
        if m:
            if not isinstance(value, dict):
                errors.append(f"{path}: expected a map")
                return
            for k, v in value.items():
                walk(v, m.group(1), f"{path}.{k}", errors)
            return
        if typ == "str":
            if not isinstance(value, str):
                errors.append(f"{path}: expected a string, got {value!r}")
            return
        if typ == "int":
            if not isinstance(value, int) or isinstance(value, bool):
                errors.append(f"{path}: expected an integer, got {value!r}")
            return
        if typ == "bool":
            if not isinstance(value, bool):
                errors.append(f"{path}: expected true/false, got {value!r}")
            return
        if typ in ("object", "datetime", "float"):
            return
        cls = model(typ)
        if cls is None:
            errors.append(f"{path}: unknown model {typ}")
            return
        if not isinstance(value, dict):
            errors.append(f"{path}: expected a {typ} map")
            return
        by_json = {j: a for a, j in cls.attribute_map.items()}
        for k, v in value.items():
            if k not in by_json:
                errors.append(f"{path}: unknown field '{k}' of {typ}")
                continue
            walk(v, cls.openapi_types[by_json[k]], f"{path}.{k}", errors)
        # required fields: the model's setters refuse None for them
        try:
            cls(**{by_json[k]: v for k, v in value.items() if k in by_json}, local_vars_configuration=conf)
        except ValueError as e:
            errors.append(f"{path}: {e}")

    for f, o in objs:
        group_version = o.get("apiVersion", "")
        version = group_version.split("/")[-1]
        name = f"{version[0].upper()}{version[1:]}{o.get('kind', '')}"
        if model(name) is None:
            check(False, f"{f}: no API model {name} for {group_version} {o.get('kind')}")
            continue
        errors = []
        walk(o, name, f"{o['kind']}/{o['metadata']['name']}", errors)
        for e in errors:
            check(False, f"{f}: {e}")
        if not errors:
            check(True, f"{f}: {name}")


# --- 3. the run ----------------------------------------------------------------------------------

def pod_spec(o):
    if o["kind"] in ("Deployment", "StatefulSet"):
        return o["spec"]["template"]["spec"], o["spec"]["template"]["metadata"].get("labels", {})
    return None, None


def run_check(objs):
    by_kind = {}
    for _, o in objs:
        by_kind.setdefault(o["kind"], {})[o["metadata"]["name"]] = o
    cms = by_kind.get("ConfigMap", {})
    config_text = cms.get("coins-config", {}).get("data", {}).get("breakout.yaml")
    check(config_text is not None, "ConfigMap coins-config holds breakout.yaml")
    config = yaml.safe_load(config_text or "{}") or {}
    cluster = cms.get("coins-cluster", {}).get("data", {})
    workloads = {**by_kind.get("Deployment", {}), **by_kind.get("StatefulSet", {})}

    sts = by_kind.get("StatefulSet", {})
    shards = config.get("run", {}).get("shards")
    check(sts.get("coins-replay", {}).get("spec", {}).get("replicas") == shards,
          f"StatefulSet coins-replay has run.shards ({shards}) replicas")

    def env_of(w):
        spec, _ = pod_spec(w)
        env = dict(cluster) if any("configMapRef" in e for c in spec["containers"] for e in c.get("envFrom", [])) else {}
        for c in spec["containers"]:
            for e in c.get("env", []):
                if "value" in e:
                    env[e["name"]] = e["value"]
        return env

    if "coins-actor" in sts:
        actors = env_of(sts["coins-actor"]).get("COINS_ACTORS")
        check(str(sts["coins-actor"]["spec"]["replicas"]) == actors,
              f"StatefulSet coins-actor: replicas equal COINS_ACTORS ({actors})")

    # workloads: selector within the pod labels, coins-pod roles, ConfigMaps and claims defined
    claims = set(by_kind.get("PersistentVolumeClaim", {}))
    for name, w in workloads.items():
        spec, labels = pod_spec(w)
        sel = w["spec"]["selector"]["matchLabels"]
        check(all(labels.get(k) == v for k, v in sel.items()), f"{name}: selector matches its pod labels")
        for c in spec["containers"]:
            cmd = c.get("command", [])
            check(len(cmd) >= 2 and cmd[0] == "coins-pod" and cmd[1] in ROLES, f"{name}: runs coins-pod ROLE ({cmd})")
            for e in c.get("envFrom", []):
                ref = e.get("configMapRef", {}).get("name")
                check(ref in cms, f"{name}: envFrom ConfigMap {ref} defined")
            mounts = {m["name"] for m in c.get("volumeMounts", [])}
            vols = {v["name"] for v in spec.get("volumes", [])}
            vols |= {t["metadata"]["name"] for t in w["spec"].get("volumeClaimTemplates", [])}
            check(mounts <= vols, f"{name}: every volumeMount has a volume ({sorted(mounts - vols)})")
            check("/dev/shm" in {m["mountPath"] for m in c.get("volumeMounts", [])},
                  f"{name}: /dev/shm is a volume of its own (Fast DDS shared memory)")
        for v in spec.get("volumes", []):
            if "configMap" in v:
                check(v["configMap"]["name"] in cms, f"{name}: ConfigMap {v['configMap']['name']} defined")
            if "persistentVolumeClaim" in v:
                claim = v["persistentVolumeClaim"]["claimName"]
                check(claim in claims, f"{name}: claim {claim} defined")
        if w["kind"] == "StatefulSet":
            svc = by_kind.get("Service", {}).get(w["spec"]["serviceName"])
            check(svc is not None and svc["spec"].get("clusterIP") == "None",
                  f"{name}: serviceName {w['spec']['serviceName']} is a headless Service")
        if w["kind"] == "Deployment":
            check(w["spec"].get("replicas") == 1 and w["spec"].get("strategy", {}).get("type") == "Recreate",
                  f"{name}: one pod at a time (replicas 1, strategy Recreate)")

    # every Service selects the pods of exactly one workload
    for name, s in by_kind.get("Service", {}).items():
        sel = s["spec"].get("selector", {})
        hits = [w for w, o in workloads.items() if all(pod_spec(o)[1].get(k) == v for k, v in sel.items())]
        check(len(hits) == 1 if s["spec"].get("clusterIP") != "None" else len(hits) >= 1,
              f"Service {name} selects the pods of {hits}")

    # COINS_DISCOVERY: Services with the entry's UDP port, in front of the server of that index
    discovery = cluster.get("COINS_DISCOVERY", "")
    entries = [e.strip() for e in discovery.split(",") if e.strip()]
    check(1 <= len(entries) <= 2, f"COINS_DISCOVERY lists a server and at most a backup ({discovery})")
    for index, entry in enumerate(entries):
        host, _, port = entry.rpartition(":")
        svc = by_kind.get("Service", {}).get(host)
        check(svc is not None, f"COINS_DISCOVERY {entry}: a Service {host}")
        if svc is None:
            continue
        ports = [(p.get("protocol", "TCP"), p["port"], p.get("targetPort", p["port"])) for p in svc["spec"]["ports"]]
        check(("UDP", int(port), int(port)) in ports, f"Service {host}: UDP {port} to {port}")
        targets = [o for o in workloads.values()
                   if all(pod_spec(o)[1].get(k) == v for k, v in svc["spec"]["selector"].items())]
        check(len(targets) == 1 and env_of(targets[0]).get("COINS_ID") == str(index)
              and pod_spec(targets[0])[0]["containers"][0]["command"][1] == "discovery",
              f"Service {host}: in front of discovery server {index}")


def main():
    objs = load()
    schema_check(objs)
    run_check(objs)
    print(f"{passed} passed, {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
