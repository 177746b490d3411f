"""Independent check of tmlut's Belcour-Bati-Barla Fresnel basis.

Builds the same construction as `src/recipes/belcour.rs` (see docs/tables.md) with
NumPy's full SVD instead of tmlut's orthogonal iteration, and prints the singular values, a few
basis values and the probe cosines. The values asserted in the test
`recipes::belcour::tests::basis_matches_an_independent_full_svd` come from this script.

Run: python3 notebooks/belcour_basis.py   (needs numpy)
"""
import numpy as np
n=1000
c=np.linspace(0,1,n)
def fres(c,eta,k):
    c2=c*c; s2=1-c2; t0=eta**2-k**2-s2; ab=np.sqrt(t0*t0+4*eta**2*k**2); a=np.sqrt(np.maximum(0,0.5*(ab+t0)))
    t1=ab+c2; t2=2*a*c; rs=(t1-t2)/(t1+t2); t3=c2*ab+s2*s2; t4=t2*s2; rp=rs*(t3-t4)/(t3+t4); return 0.5*(rs+rp)
def gul(r,g):
    n_=g*(1-r)/(1+r)+(1-g)*(1+np.sqrt(r))/(1-np.sqrt(r)); k2=(r*(1+n_)**2-(n_-1)**2)/(1-r); return n_,np.sqrt(max(k2,0))
rows=[]
for i in range(n):
    if i==0: e,k=1.1,0.0
    else:
        r=i/1000
        if r<=0.01:
            rr=min((r/0.01)/(1-1e-5)+1e-5,1-1e-5); e,k=gul(rr,1.0)
        else: e,k=1.01+1.99*(r-0.01)/0.99,0.0
    F=fres(c,e,k); f1=fres(np.array([1.0]),e,k)[0]; rows.append((F-f1)/(1-f1))
A=np.array(rows)
u,s,vt=np.linalg.svd(A); print('s1',s[:4])
b1=np.abs(vt[0]); b1/=b1.max()
R=A-b1
u,s,vt=np.linalg.svd(R); print('s2',s[:5])
b2=vt[0]/np.abs(vt[0]).max(); 
if b2[np.argmax(np.abs(b2))]<0: b2=-b2
i1=np.argmax(b2); b3=vt[1]/np.abs(vt[1]).max()
if b3[i1]<0: b3=-b3
print('ct1',c[i1], 'b1[500]',b1[500],'b2[500]',b2[500],'b3[500]',b3[500])
d=np.diff(b3); ext=[i for i in range(1,n-1) if d[i-1]*d[i]<=0 and b3[i]!=0]; print('ext',[(c[i],b3[i]) for i in ext])
