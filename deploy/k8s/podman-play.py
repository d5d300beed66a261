#!/usr/bin/python3
"""Turns the manifests of deploy/k8s into one file that `podman kube play` (podman 4.3, Debian
bookworm) can start on a single machine, for a test without a cluster:

    deploy/k8s/podman-play.py [--image NAME] [--set KEY=VALUE ...] > play.yaml
    podman network create coins-k8s            # a network with DNS (aardvark-dns)
    podman kube play --network coins-k8s play.yaml
    podman kube down play.yaml

What podman lacks is replaced as a cluster would do it:
  - StatefulSet: replicas Pods NAME-I with host name NAME-I (the ordinal coins-pod reads), and the
    claims of volumeClaimTemplates as PersistentVolumeClaims TEMPLATE-NAME-I (podman volumes);
  - Deployment: one Pod named after it (all of ours have one replica);
  - containerPorts: dropped (podman would publish them on the host);
  - Service: dropped. A pod's name resolves to its IP on a podman network with DNS, and each
    discovery Deployment is named like its Service, so COINS_DISCOVERY resolves to the servers'
    pod IPs (in a cluster: the Services' cluster IPs, which forward to those pods);
  - env from the downward API (POD_IP): dropped; coins-pod then takes the address of the pod's
    host name;
  - pod securityContext runAsUser/fsGroup: the claims get podman's volume.podman.io/uid and gid
    annotations so that the volumes belong to that user (podman has no fsGroup);
  - emptyDir: at /dev/shm dropped (a podman pod has a 64 MB /dev/shm of its own; podman 4.3
    cannot give a pod a tmpfs volume its non-root user may write); elsewhere (the actors' /data)
    a volume POD-VOLUME of the pod's user (podman's emptyDir would belong to root);
  - --set KEY=VALUE adds `--set KEY=VALUE` to every coins-pod command (e.g. run.steps=20000).
"""
import argparse
import copy
import os
import sys

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))


def manifests():
    kust = yaml.safe_load(open(os.path.join(HERE, "kustomization.yaml")))
    for f in kust["resources"]:
        for d in yaml.safe_load_all(open(os.path.join(HERE, f))):
            if d is not None:
                yield d


def pod(name, template, image, sets, claims_owner):
    spec = copy.deepcopy(template["spec"])
    spec["hostname"] = name
    spec.pop("terminationGracePeriodSeconds", None)
    sc = spec.get("securityContext", {})
    uid, gid = sc.get("runAsUser"), sc.get("fsGroup", sc.get("runAsGroup"))
    sc.pop("fsGroup", None)
    empty = {v["name"]: v for v in spec.get("volumes", []) if "emptyDir" in v}
    for c in spec["containers"]:
        c["image"] = image
        if c.get("command", [""])[0] == "coins-pod":
            for s in sets:
                c["command"] += ["--set", s]
        c["env"] = [e for e in c.get("env", []) if "valueFrom" not in e or "configMapKeyRef" in e["valueFrom"]]
        # podman would publish containerPorts on the host; the pods reach each other on the network
        c.pop("ports", None)
        # /dev/shm: the pod's own (podman gives every pod a 64 MB tmpfs, mode 1777)
        c["volumeMounts"] = [m for m in c.get("volumeMounts", [])
                             if not (m["name"] in empty and m["mountPath"] == "/dev/shm")]
    # any other emptyDir: a volume of the pod's user (podman's emptyDir would belong to root)
    extra_claims = []
    spec["volumes"] = [v for v in spec.get("volumes", []) if "emptyDir" not in v]
    used = {m["name"] for c in spec["containers"] for m in c["volumeMounts"]}
    for vname in sorted(set(empty) & used):
        claim = f"{name}-{vname}"
        extra_claims.append(pvc(claim, uid, gid))
        spec["volumes"].append({"name": vname, "persistentVolumeClaim": {"claimName": claim}})
    for v in spec["volumes"]:
        if "persistentVolumeClaim" in v:
            claims_owner[v["persistentVolumeClaim"]["claimName"]] = (uid, gid)
    labels = dict(template.get("metadata", {}).get("labels", {}))
    return {"apiVersion": "v1", "kind": "Pod", "metadata": {"name": name, "labels": labels}, "spec": spec}, extra_claims


def pvc(name, uid, gid, storage="1Gi", labels=None):
    annotations = {}
    if uid is not None:
        annotations["volume.podman.io/uid"] = str(uid)
    if gid is not None:
        annotations["volume.podman.io/gid"] = str(gid)
    return {"apiVersion": "v1", "kind": "PersistentVolumeClaim",
            "metadata": {"name": name, "labels": labels or {}, "annotations": annotations},
            "spec": {"accessModes": ["ReadWriteOnce"], "resources": {"requests": {"storage": storage}}}}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--image", default="localhost/coins:latest")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    a = ap.parse_args()
    configmaps, claims, pods = [], [], []
    claims_owner = {}
    for o in manifests():
        kind, name = o["kind"], o["metadata"]["name"]
        if kind == "ConfigMap":
            configmaps.append(o)
        elif kind == "PersistentVolumeClaim":
            claims.append(o)
        elif kind == "Deployment":
            p, extra = pod(name, o["spec"]["template"], a.image, a.set, claims_owner)
            pods.append(p)
            claims += extra
        elif kind == "StatefulSet":
            for i in range(o["spec"].get("replicas", 1)):
                t = copy.deepcopy(o["spec"]["template"])
                for tmpl in o["spec"].get("volumeClaimTemplates", []):
                    claim = f"{tmpl['metadata']['name']}-{name}-{i}"
                    t["spec"].setdefault("volumes", []).append(
                        {"name": tmpl["metadata"]["name"], "persistentVolumeClaim": {"claimName": claim}})
                    claims.append({"apiVersion": "v1", "kind": "PersistentVolumeClaim",
                                   "metadata": {"name": claim, "labels": tmpl["metadata"].get("labels", {})},
                                   "spec": tmpl["spec"]})
                p, extra = pod(f"{name}-{i}", t, a.image, a.set, claims_owner)
                pods.append(p)
                claims += extra
        elif kind == "Service":
            continue
        else:
            sys.exit(f"podman-play.py: {kind} {name}: no podman equivalent")
    for c in claims:
        uid, gid = claims_owner.get(c["metadata"]["name"], (None, None))
        ann = c["metadata"].setdefault("annotations", {})
        if uid is not None:
            ann.setdefault("volume.podman.io/uid", str(uid))
        if gid is not None:
            ann.setdefault("volume.podman.io/gid", str(gid))
    print("# made by deploy/k8s/podman-play.py from deploy/k8s (podman kube play, one machine)")
    yaml.safe_dump_all(configmaps + claims + pods, sys.stdout, sort_keys=False, default_flow_style=False)


if __name__ == "__main__":
    main()
