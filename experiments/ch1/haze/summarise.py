import json, sys, numpy as np
from scipy.stats import mannwhitneyu
d=json.load(open(sys.argv[1]))
r=[x for x in d if "best" in x and x["error_m"] is not None]
ok=np.array([x["error_m"]<=1000 for x in r]); c=np.array([x["best"]["corr"] for x in r]); conf=np.array([x["confidence"] for x in r])
ru=np.array([x.get("runner_up",{}).get("corr",np.nan) for x in r])
fin=np.isfinite(c)
print("rows",len(r),"finite corr",fin.sum(), "right",ok.sum())
print("corr right: median %.2f  mean %.2f"%(np.median(c[fin&ok]),c[fin&ok].mean()))
print("corr wrong: median %.2f  mean %.2f"%(np.median(c[fin&~ok]),c[fin&~ok].mean()))
u=mannwhitneyu(c[fin&~ok],c[fin&ok]); print("AUC (wrong>right)", u.statistic/(fin&~ok).sum()/(fin&ok).sum(), "p", u.pvalue)
dd=c-ru; f2=np.isfinite(dd)
u=mannwhitneyu(dd[f2&~ok],dd[f2&ok]); print("diff best-runner AUC", u.statistic/(f2&~ok).sum()/(f2&ok).sum(), "p", u.pvalue, "n", f2.sum())
hc=conf>0.5
print("conf>0.5 right corr", np.round(np.sort(c[hc&ok]),2)); print("conf>0.5 wrong corr", np.round(np.sort(c[hc&~ok]),2))
