import sys, time, numpy as np
from skyrender.dem import load_dem
from skyrender.render import Terrain, render_skylines
from skyrender.render.skyline import strided_skylines
from skyrender.camera import Intrinsics
from skyrender.benchmarks import real_localize as rl
out={}; times={}
rng=np.random.default_rng(0)
for name,dem in (('jacks',load_dem('builtin:jacksboro')),('ch1',rl.place_dem(46.5572,7.8352)[0])):
    t=Terrain(dem); cx,cy=dem.centre; span=8000 if name=='jacks' else 20000
    P=1500
    xy=np.column_stack([cx+rng.uniform(-span,span,P), cy+rng.uniform(-span,span,P)])
    z=dem.ground(xy[:,0],xy[:,1])+2
    poses=np.column_stack([xy,z,rng.uniform(0,360,P),rng.uniform(-10,25,P),rng.uniform(-8,8,P)])
    for kname,K,tol in (('small',Intrinsics.from_fov(50,256,192),0.125),('full',Intrinsics.from_fov(55,1024,768),0.05),('odd',Intrinsics.from_fov(35,333,250),0.1)):
        n=P if kname!='full' else 150
        t0=time.perf_counter()
        a,d=render_skylines(t,poses[:n],K,tol=tol,with_distance=True)
        times[f'{name}-{kname}']=time.perf_counter()-t0
        out[f'{name}-{kname}-v']=a; out[f'{name}-{kname}-d']=d
    t0=time.perf_counter(); r,c=strided_skylines(t,poses,Intrinsics.from_fov(50,1024,768),32,0.5); times[f'{name}-stride32']=time.perf_counter()-t0
    out[f'{name}-stride32']=r
    t0=time.perf_counter(); r=render_skylines(t,poses[:5],Intrinsics.from_fov(50,1024,768),tol=0.05); times[f'{name}-single']=time.perf_counter()-t0
    out[f'{name}-single']=r
    lev=poses.copy(); lev[:,4:]=0
    out[f'{name}-near']=render_skylines(t,lev[:300],Intrinsics.from_fov(50,256,192),tol=0.125,near_m=300)
np.savez(sys.argv[1],**out)
print({k:round(v,2) for k,v in times.items()})
