import json,sys
a=json.load(open(sys.argv[1])); b=json.load(open(sys.argv[2]))
A={r['photo']:r for r in a['photos']}; B={r['photo']:r for r in b['photos']}
common=[k for k in B if k in A]
def ref(r,key):
    rs=[r[f'rank_{k}'][key] for k in ('cost','score') if r[f'rank_{k}'][key] is not None]
    return min(rs) if rs else None
for key in ('250','500','1000'):
    na=sum(ref(A[k],key) is not None and ref(A[k],key)<=8 for k in common)
    nb=sum(ref(B[k],key) is not None and ref(B[k],key)<=8 for k in common)
    fa=sum(A[k]['rank_cost'][key] is not None for k in common); fb=sum(B[k]['rank_cost'][key] is not None for k in common)
    print(key, len(common), 'with a pose', fa, fb, 'among refined', na, nb)
for k in common:
    print(k, [ (round(R[k]['nearest_pose_m'] or -1), ref(R[k],'1000')) for R in (A,B)])
